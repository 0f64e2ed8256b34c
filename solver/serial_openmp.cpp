#include "solver/serial_openmp.h"

#include <mutex>

#include <dlfcn.h>
#include <omp.h>

namespace oslam {
namespace {

// Scopes entered and not yet left on this thread. The OpenMP setting alone
// (max-active-levels) cannot tell GOMP_parallel whether to skip libgomp: a
// user may set it too.
thread_local int serial_openmp_depth = 0;

}  // namespace

SerialOpenMpScope::SerialOpenMpScope() : saved_levels_(omp_get_max_active_levels()) {
  omp_set_max_active_levels(0);
  ++serial_openmp_depth;
}

SerialOpenMpScope::~SerialOpenMpScope() {
  --serial_openmp_depth;
  omp_set_max_active_levels(saved_levels_);
}

bool SerialOpenMpScope::Active() {
  return serial_openmp_depth > 0;
}

void UseOneBlasThread() {
  static std::once_flag once;
  std::call_once(once, [] {
    using SetNumThreads = void (*)(int);
    if (auto set = reinterpret_cast<SetNumThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads")))
      set(1);
  });
}

}  // namespace oslam

// libgomp's entry point for `#pragma omp parallel` (see the header). CHOLMOD
// schedules its loops statically on omp_get_num_threads() and
// omp_get_thread_num(), so a body run directly on the calling thread does
// all the region's work. Inside an OpenMP region the call goes to libgomp
// (a nested team of one): run directly, the body would see the enclosing
// team's thread count and number and do only its share.
extern "C" void GOMP_parallel(void (*fn)(void*), void* data, unsigned num_threads, unsigned flags) {
  using Real = void (*)(void (*)(void*), void*, unsigned, unsigned);
  static const Real real = reinterpret_cast<Real>(dlvsym(RTLD_NEXT, "GOMP_parallel", "GOMP_4.0"));
  if ((oslam::SerialOpenMpScope::Active() && omp_get_level() == 0) || !real) {
    fn(data);
    return;
  }
  real(fn, data, num_threads, flags);
}
