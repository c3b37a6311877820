#include "kernels/process_memory.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace tensegrity {
namespace {

// Blocks up to this size come from the heap rather than from mmap (glibc's
// default starts at 128 KiB; 32 MiB is the largest it accepts on 64-bit
// systems), and the heap keeps up to this much free space.
constexpr int kHeapBlockLimitBytes = 32 << 20;
constexpr int kKeptFreeBytes = 512 << 20;

}  // namespace

void keep_freed_memory_in_process() {
#if defined(__GLIBC__)
  static const bool done = [] {
    mallopt(M_MMAP_THRESHOLD, kHeapBlockLimitBytes);
    mallopt(M_TRIM_THRESHOLD, kKeptFreeBytes);
    return true;
  }();
  (void)done;
#endif
}

}  // namespace tensegrity
