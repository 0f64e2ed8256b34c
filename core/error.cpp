#include "core/error.h"

namespace oslam {

Error Error::InFile(const std::string& path, const std::string& what) {
  return Error(path + ": " + what);
}

Error Error::AtLine(const std::string& path, int line, const std::string& what) {
  return Error(path + ":" + std::to_string(line) + ": " + what);
}

}  // namespace oslam
