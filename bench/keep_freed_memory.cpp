// Linked into every benchmark binary: the solves run one after another in one
// process, as in batch, stress-test and the server, so freed memory stays in
// the process for the next solve (kernels/process_memory.hpp) from the start.
#include "kernels/process_memory.hpp"

namespace {

[[maybe_unused]] const bool kFreedMemoryKept = [] {
  tensegrity::keep_freed_memory_in_process();
  return true;
}();

}  // namespace
