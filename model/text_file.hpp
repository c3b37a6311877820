#pragma once
// Whole-file reading and atomic writing, for every file the model reads or writes.
#include <string>

namespace tensegrity {

// The whole content of a file, for every reader of the model: InputError when it
// cannot be opened, is a directory, or holds more than 256 MiB (an endless
// device stops there); a FIFO without a writer reads as empty instead of hanging.
std::string read_text_file(const std::string& path);

// Writes text to `path` through a temporary file and a rename ("-" = stdout),
// so that a failure leaves no partial file; an existing device or pipe
// (/dev/null, a FIFO) is written in place instead of being replaced.
void write_text_file_atomically(const std::string& path, const std::string& text);

}  // namespace tensegrity
