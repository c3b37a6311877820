#include "model/text_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <string>

#include "model/errors.hpp"

namespace tensegrity {

namespace {

// Files larger than this are refused rather than read into memory whole.
constexpr std::size_t kMaxFileBytes = std::size_t{256} << 20;

std::string read_whole_file(const std::string& path) {
  auto fail = [&path](const std::string& what, int error) {
    return InputError(path, "", what + (error != 0 ? std::string(": ") + std::strerror(error) : std::string()));
  };
  // O_NONBLOCK: opening a FIFO without a writer must not wait forever (it then
  // reads as empty); it is cleared at once so that reading a pipe still works.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw fail("cannot open file", errno);
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat info {};
  if (::fstat(fd, &info) != 0) throw fail("cannot read file", errno);
  if (S_ISDIR(info.st_mode)) throw InputError(path, "", "cannot read file: it is a directory");
  if (S_ISREG(info.st_mode) && static_cast<std::uintmax_t>(info.st_size) > kMaxFileBytes)
    throw InputError(path, "", "file too large (" + std::to_string(info.st_size) + " bytes; the limit is " +
                                   std::to_string(kMaxFileBytes) + ")");
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags < 0 || ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) != 0) throw fail("cannot read file", errno);
  std::string text;
  char chunk[1 << 16];
  for (;;) {
    const ssize_t got = ::read(fd, chunk, sizeof chunk);
    if (got < 0) {
      if (errno == EINTR) continue;
      throw fail("cannot read file", errno);
    }
    if (got == 0) break;
    // Devices and pipes have no size: an endless one (/dev/zero) stops here.
    if (text.size() + static_cast<std::size_t>(got) > kMaxFileBytes)
      throw InputError(path, "", "file too large (more than " + std::to_string(kMaxFileBytes) + " bytes)");
    text.append(chunk, static_cast<std::size_t>(got));
  }
  return text;
}

void write_all(int fd, const std::string& text, const std::string& path) {
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t k = ::write(fd, text.data() + written, text.size() - written);
    if (k < 0) {
      if (errno == EINTR) continue;
      const std::string reason = std::string("cannot write output file: ") + std::strerror(errno);
      ::close(fd);
      throw InputError(path, "", reason);
    }
    written += static_cast<std::size_t>(k);
  }
}

void write_in_place(const std::string& path, const std::string& text) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(path, "", std::string("cannot open output file: ") + std::strerror(errno));
  write_all(fd, text, path);
  if (::close(fd) != 0) throw InputError(path, "", std::string("cannot write output file: ") + std::strerror(errno));
}

}  // namespace

std::string read_text_file(const std::string& path) { return read_whole_file(path); }

void write_text_file_atomically(const std::string& path, const std::string& text) {
  if (path == "-") {
    std::cout << text;
    std::cout.flush();
    if (!std::cout) throw InputError("-", "", "cannot write to standard output");
    return;
  }
  const std::filesystem::path target(path);
  std::error_code ec;
  if (std::filesystem::is_directory(target, ec))
    throw InputError(path, "", "cannot write: it is a directory");
  // A device or a pipe (/dev/null, a FIFO) is written in place: renaming a
  // file over it would replace it.
  const std::filesystem::file_status existing = std::filesystem::status(target, ec);
  if (!ec && std::filesystem::exists(existing) && !std::filesystem::is_regular_file(existing)) {
    write_in_place(path, text);
    return;
  }
  // The temporary file lives in the target's directory so that rename() is
  // atomic and a failure leaves no partial output under the final name.
  const std::filesystem::path directory = target.has_parent_path() ? target.parent_path() : ".";
  std::string temp = (directory / (std::string(".") + target.filename().string() + ".tmp-XXXXXX")).string();
  const int fd = mkstemp(temp.data());
  if (fd < 0) throw InputError(path, "", std::string("cannot create output file: ") + std::strerror(errno));
  auto fail = [&](const char* what) {
    const std::string reason = std::string(what) + ": " + std::strerror(errno);
    ::close(fd);
    ::unlink(temp.c_str());
    throw InputError(path, "", reason);
  };
  // mkstemp creates mode 0600; give the file the mode a plain open() would.
  const mode_t mask = ::umask(0);
  ::umask(mask);
  if (::fchmod(fd, 0666 & ~mask) != 0) fail("cannot set output file mode");
  try {
    write_all(fd, text, path);
  } catch (const InputError&) {
    ::unlink(temp.c_str());
    throw;
  }
  if (::close(fd) != 0) {
    const std::string reason = std::string("cannot write output file: ") + std::strerror(errno);
    ::unlink(temp.c_str());
    throw InputError(path, "", reason);
  }
  if (std::rename(temp.c_str(), path.c_str()) != 0) {
    const std::string reason = std::string("cannot create output file: ") + std::strerror(errno);
    ::unlink(temp.c_str());
    throw InputError(path, "", reason);
  }
}

}  // namespace tensegrity
