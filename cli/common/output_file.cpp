#include "netkf/cli/common/output_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ext/stdio_filebuf.h>  // a stream over the descriptor that was checked (no second open by name)
#include <filesystem>
#include <random>

#include "netkf/cli/common/exit_code.hpp"
#include "netkf/support/input_file.hpp"

namespace netkf::cli {
namespace {

namespace fs = std::filesystem;

std::string named(const FileArg& f) { return f.path + " (" + f.option + ")"; }

[[noreturn]] void refuse(const std::string& message) { fail(ExitCode::bad_usage, message); }

std::string errno_text(int e) { return std::strerror(e); }

/// The file a path names once written: itself, or what its symbolic link points to.
fs::path written_path(const std::string& path) {
  std::error_code ec;
  if (fs::is_symlink(fs::symlink_status(path, ec))) {
    const fs::path target = fs::canonical(path, ec);
    if (!ec) return target;
  }
  return path;
}

struct FileIdentity {
  bool exists = false;
  dev_t dev = 0;
  ino_t ino = 0;
  fs::path canonical;  // of the path (its existing prefix resolved)
};

FileIdentity identity_of(const std::string& path) {
  FileIdentity id;
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    id.exists = true;
    id.dev = st.st_dev;
    id.ino = st.st_ino;
  }
  std::error_code ec;
  id.canonical = fs::weakly_canonical(fs::absolute(path, ec), ec);
  if (ec) id.canonical = fs::absolute(path, ec).lexically_normal();
  return id;
}

bool same_file(const FileIdentity& a, const FileIdentity& b) {
  if (a.exists && b.exists) return a.dev == b.dev && a.ino == b.ino;
  return a.canonical == b.canonical;
}

/// A stream that owns a descriptor (the buffer is a base, built before the ostream).
struct FdBuffer {
  explicit FdBuffer(int fd) : buf(fd, std::ios::out | std::ios::binary) {}
  __gnu_cxx::stdio_filebuf<char> buf;  // closes the descriptor
};

class FdOutputStream : private FdBuffer, public std::ostream {
 public:
  explicit FdOutputStream(int fd) : FdBuffer(fd), std::ostream(&buf) {}
  ~FdOutputStream() override { flush(); }
};

/// A new file beside `target`, created here (O_EXCL): ".NAME.netkf-XXXXXXXX".
std::pair<int, std::string> create_temporary_beside(const fs::path& target, const FileArg& output) {
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::random_device random;
  for (int attempt = 0; attempt < 16; ++attempt) {
    char suffix[16];
    std::snprintf(suffix, sizeof suffix, "%08x", random());
    const std::string name = (dir / ("." + target.filename().string() + ".netkf-" + suffix)).string();
    const int fd = ::open(name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);  // the umask applies
    if (fd >= 0) return {fd, name};
    if (errno != EEXIST) refuse("cannot write " + named(output) + ": " + errno_text(errno));
  }
  refuse("cannot write " + named(output) + ": no free temporary name beside it");
}

}  // namespace

void check_output_path(const FileArg& output) {
  if (output.path.empty()) refuse(output.option + ": an empty path");
  struct stat st {};
  if (::lstat(output.path.c_str(), &st) != 0) {
    if (errno != ENOENT) refuse("cannot write " + named(output) + ": " + errno_text(errno));
    const fs::path parent = fs::path(output.path).parent_path();
    std::error_code ec;
    if (!parent.empty() && !fs::is_directory(parent, ec))
      refuse("cannot write " + named(output) + ": the directory " + parent.string() + " does not exist");
    return;
  }
  if (S_ISLNK(st.st_mode) && ::stat(output.path.c_str(), &st) != 0)
    refuse("cannot write " + named(output) + ": it is a symbolic link to " +
           (errno == ENOENT ? std::string("nothing (a missing file)") : errno_text(errno)));
  if (!S_ISREG(st.st_mode))
    refuse(named(output) + " is " + std::string(file_kind_word(st.st_mode)) +
           ", not a regular file: nothing was written (give a file path)");
}

void check_output_files(const std::vector<FileArg>& outputs, const std::vector<FileArg>& inputs) {
  std::vector<FileIdentity> ids;
  for (const auto& o : outputs) {
    check_output_path(o);
    ids.push_back(identity_of(o.path));
  }
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j)
      if (same_file(ids[i], ids[j]))
        refuse(outputs[j].option + " " + outputs[j].path + " and " + outputs[i].option + " " + outputs[i].path +
               " are one file: give each output its own");
    for (const auto& in : inputs)
      if (!in.path.empty() && same_file(ids[i], identity_of(in.path)))
        refuse(outputs[i].option + " " + outputs[i].path + " is " + in.option + " " + in.path +
               ": an output may not overwrite an input");
  }
}

void refuse_existing(const std::vector<FileArg>& outputs, std::string_view how_to_replace) {
  for (const auto& o : outputs) {
    struct stat st {};
    if (::lstat(o.path.c_str(), &st) == 0)
      refuse(named(o) + " exists: " + std::string(how_to_replace) + " to replace it, or name another file");
  }
}

std::unique_ptr<std::ostream> open_output_stream(const FileArg& output) {
  check_output_path(output);
  // No O_TRUNC: the kind of an existing file is checked on the descriptor before anything is
  // emptied. O_NONBLOCK: a FIFO without a reader fails at once instead of waiting.
  const int fd = ::open(output.path.c_str(), O_WRONLY | O_CREAT | O_NONBLOCK | O_CLOEXEC, 0666);
  if (fd < 0) refuse("cannot write " + named(output) + ": " + errno_text(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    refuse(named(output) + " is " + std::string(file_kind_word(st.st_mode)) +
           ", not a regular file: nothing was written (give a file path)");
  }
  if (::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK) != 0 || ::ftruncate(fd, 0) != 0) {
    const int e = errno;
    ::close(fd);
    refuse("cannot write " + named(output) + ": " + errno_text(e));
  }
  return std::make_unique<FdOutputStream>(fd);
}

void write_output_file(const FileArg& output, std::string_view text, bool sync) {
  check_output_path(output);
  const fs::path target = written_path(output.path);
  struct stat old {};
  const bool existed = ::stat(target.c_str(), &old) == 0;
  const auto made = create_temporary_beside(target, output);
  const int fd = made.first;
  const std::string& temporary = made.second;
  auto give_up = [&](int e) {
    ::close(fd);
    ::unlink(temporary.c_str());  // made here, above
    refuse("cannot write " + named(output) + ": " + errno_text(e));
  };
  for (std::size_t done = 0; done < text.size();) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) give_up(errno);
    done += static_cast<std::size_t>(n);
  }
  if (sync && ::fsync(fd) != 0) give_up(errno);
  if (existed && ::fchmod(fd, old.st_mode & 07777) != 0) give_up(errno);
  if (::close(fd) != 0) {
    const int e = errno;
    ::unlink(temporary.c_str());
    refuse("cannot write " + named(output) + ": " + errno_text(e));
  }
  // Only over a regular file (checked again: the check above was a moment ago).
  struct stat now {};
  if (::lstat(target.c_str(), &now) == 0 && !S_ISREG(now.st_mode)) {
    ::unlink(temporary.c_str());
    refuse(named(output) + " is not a regular file: nothing was written (give a file path)");
  }
  if (::rename(temporary.c_str(), target.c_str()) != 0) {
    const int e = errno;
    ::unlink(temporary.c_str());
    refuse("cannot write " + named(output) + ": " + errno_text(e));
  }
}

}  // namespace netkf::cli
