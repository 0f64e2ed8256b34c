// A started CHOLMOD workspace, for the tests that build and factor CHOLMOD
// matrices themselves.
#pragma once

#include <cholmod.h>

namespace oslam {
namespace testing {

struct CholmodWorkspace {
  cholmod_common cc;

  CholmodWorkspace() {
    cholmod_start(&cc);
    cc.print = 0;
  }
  ~CholmodWorkspace() { cholmod_finish(&cc); }
  CholmodWorkspace(const CholmodWorkspace&) = delete;
  CholmodWorkspace& operator=(const CholmodWorkspace&) = delete;
};

}  // namespace testing
}  // namespace oslam
