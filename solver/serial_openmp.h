// Runs CHOLMOD on the calling thread only. Two process-wide changes live
// here, and one per-thread setting:
//
// 1. GOMP_parallel is replaced for the whole process. serial_openmp.cpp
//    defines libgomp's entry point for `#pragma omp parallel` with C
//    linkage. Every program that uses SparseSolver links that definition
//    from the static library (SparseSolver uses SerialOpenMpScope, whose
//    members live in the same object file), and the dynamic linker then
//    binds every call of GOMP_parallel in the process to it:
//    the program's own regions and those of every shared library that calls
//    libgomp (CHOLMOD among them). The replacement runs the region's body
//    directly on the calling thread when that thread is inside a
//    SerialOpenMpScope and outside any OpenMP region (what a team of one
//    does: omp_get_num_threads() = 1, omp_get_thread_num() = 0, though
//    omp_get_level() stays 0 in the body); every other call goes unchanged to
//    libgomp's GOMP_parallel (symbol version GOMP_4.0). If libgomp's symbol
//    cannot be found, every region in the process runs on its calling thread.
//
//    Why: CHOLMOD's supernodal code opens an OpenMP region per supernode for
//    its copies and clears (GOMP_parallel is the only OpenMP entry point it
//    calls). Even serialised, each region cost a futex system call in
//    libgomp's team hand-off: ~100 per LPA-scale factorisation, 163 k in 600
//    one-step O-SLAM proposals, 9.5 % of their cycles in the kernel.
//
// 2. OpenBLAS runs single-threaded in the whole process from the first
//    UseOneBlasThread() on (SparseSolver's constructor calls it). CHOLMOD's
//    dense kernels run on the system BLAS; a threaded BLAS splits the larger
//    supernodes over its threads, so results would depend on the machine's
//    core count (summation order), and O-SLAM's chains already occupy every
//    core. The function is looked up by name, so any BLAS links; with
//    another BLAS nothing changes. (OpenBLAS' single-threaded build is not
//    safe to call from two threads at once: with it, long_loop's O-Map
//    changed from run to run. The threaded build limited to one thread is,
//    and gives the same results as one chain thread.)
//
// 3. SerialOpenMpScope (per thread, undone on exit): OpenMP regions opened
//    by the thread while the scope lives run on it alone
//    (max-active-levels 0), and GOMP_parallel above skips libgomp for them.
//    At the solver's sizes a region costs more in thread hand-offs than its
//    work. Threads outside a scope, and the thread itself after it, see no
//    change.
#pragma once

namespace oslam {

class SerialOpenMpScope {
 public:
  SerialOpenMpScope();
  ~SerialOpenMpScope();
  SerialOpenMpScope(const SerialOpenMpScope&) = delete;
  SerialOpenMpScope& operator=(const SerialOpenMpScope&) = delete;

  // Whether the calling thread is inside a scope.
  static bool Active();

 private:
  int saved_levels_;
};

// Limits OpenBLAS, if it is the process's BLAS, to the calling thread, once
// per process (see 2. above).
void UseOneBlasThread();

}  // namespace oslam
