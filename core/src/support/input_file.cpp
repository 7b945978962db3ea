// Bounded reading of the files a user names (netkf/support/input_file.hpp).
#include "netkf/support/input_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ext/stdio_filebuf.h>  // an istream over the descriptor that was checked (no reopen by name)

namespace netkf {

struct InputFile::Impl {
  Impl(int fd) : buf(fd, std::ios::in), in(&buf) {}
  __gnu_cxx::stdio_filebuf<char> buf;  // owns and closes the descriptor
  std::istream in;
  std::string name;
  std::string what;
  std::uintmax_t max_bytes = 0;
};

std::string_view file_kind_word(unsigned st_mode) {
  switch (st_mode & S_IFMT) {
    case S_IFREG: return {};
    case S_IFDIR: return "a directory";
    case S_IFCHR: return "a character device";
    case S_IFBLK: return "a block device";
    case S_IFIFO: return "a FIFO (named pipe)";
    case S_IFSOCK: return "a socket";
    default: return "not a regular file";
  }
}

InputFile::InputFile(const std::filesystem::path& path, std::string_view what, std::uintmax_t max_bytes) {
  const std::string name = path.string();
  const std::string w(what);
  if (name.empty()) throw InputFileError("''", "an empty path is not a " + w);
  // O_NONBLOCK: opening a FIFO without a writer would wait forever; it is refused below anyway.
  const int fd = ::open(name.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw InputFileError(name, "cannot open " + w + ": " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int e = errno;
    ::close(fd);
    throw InputFileError(name, "cannot open " + w + ": " + std::strerror(e));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    throw InputFileError(name, "is " + std::string(file_kind_word(st.st_mode)) + ", not a " + w + " (give a regular file)");
  }
  if (static_cast<std::uintmax_t>(st.st_size) > max_bytes) {
    ::close(fd);
    throw InputFileError(name, std::to_string(st.st_size) + " bytes, more than a " + w + " may have (" +
                                   std::to_string(max_bytes) + ")");
  }
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  impl_ = std::make_unique<Impl>(fd);
  impl_->name = name;
  impl_->what = what;
  impl_->max_bytes = max_bytes;
}

InputFile::~InputFile() = default;

std::istream& InputFile::stream() { return impl_->in; }

std::string InputFile::read_all() {
  std::string text;
  char chunk[65536];
  for (;;) {
    impl_->in.read(chunk, sizeof chunk);
    const auto n = static_cast<std::size_t>(impl_->in.gcount());
    if (text.size() + n > impl_->max_bytes)
      throw InputFileError(impl_->name,
                           "more than a " + impl_->what + " may have (" + std::to_string(impl_->max_bytes) + " bytes)");
    text.append(chunk, n);
    if (n < sizeof chunk) break;
  }
  if (impl_->in.bad()) throw InputFileError(impl_->name, "error while reading " + impl_->what);
  return text;
}

std::string read_input_file(const std::filesystem::path& path, std::string_view what, std::uintmax_t max_bytes) {
  return InputFile(path, what, max_bytes).read_all();
}

}  // namespace netkf
