#include "kernels/blas_threads.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <mutex>

namespace tensegrity {

void use_one_blas_thread() {
  static std::once_flag once;
  std::call_once(once, [] {
    ::setenv("OPENBLAS_NUM_THREADS", "1", 1);
    ::setenv("OMP_NUM_THREADS", "1", 1);
    using SetThreads = void (*)(int);
    for (const char* symbol : {"openblas_set_num_threads", "omp_set_num_threads"})
      if (auto set = reinterpret_cast<SetThreads>(::dlsym(RTLD_DEFAULT, symbol))) set(1);
  });
}

void end_blas_thread_pool() {
  use_one_blas_thread();
  // OpenBLAS's own handler before fork(); it joins the pool's threads.
  using Shutdown = int (*)();
  if (auto shutdown = reinterpret_cast<Shutdown>(::dlsym(RTLD_DEFAULT, "blas_thread_shutdown_"))) shutdown();
}

}  // namespace tensegrity
