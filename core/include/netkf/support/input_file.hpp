#pragma once
// Files a user names as input (a scenario, an events file, a link trace, a recording) are read
// bounded: only a regular file is opened (a device such as /dev/zero or /dev/urandom, a FIFO,
// a socket or a directory is refused by its kind, never read), and no reader takes more than
// its own limit of it. A FIFO is opened without blocking, so naming one cannot hang either.
#include <cstdint>
#include <filesystem>
#include <istream>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>

namespace netkf {

/// A file that cannot be read as an input: what() is "PATH: REASON".
class InputFileError : public std::runtime_error {
 public:
  InputFileError(const std::string& path, const std::string& reason)
      : std::runtime_error(path + ": " + reason), reason_(reason) {}
  /// What is wrong, without the path ("cannot open scenario file: No such file or directory").
  const std::string& reason() const { return reason_; }

 private:
  std::string reason_;
};

/// The most a scenario or events file may hold (a 1024-sensor scenario is about 100 kB).
inline constexpr std::uintmax_t max_yaml_input_bytes = 16u << 20;

/// What a file is, in words, when it is not a regular file ("a character device", "a
/// directory", "a FIFO (named pipe)", "a socket", "a block device"); empty for a regular file.
std::string_view file_kind_word(unsigned st_mode);

/// An input file, open for reading: a regular file, at most `max_bytes` when opened. `what`
/// names it in errors ("scenario file"). Throws InputFileError naming the path and why
/// (errno's text, its kind when it is not a regular file, its size over the limit).
class InputFile {
 public:
  InputFile(const std::filesystem::path& path, std::string_view what, std::uintmax_t max_bytes);
  ~InputFile();
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;

  /// The file as a stream (for the streaming readers: they bound their lines and rows).
  std::istream& stream();
  /// The whole file, at most `max_bytes` (a file that grew past it since it was opened, or a
  /// /proc file that reports size 0, is refused when the read passes the limit).
  std::string read_all();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// InputFile(path, what, max_bytes).read_all().
std::string read_input_file(const std::filesystem::path& path, std::string_view what, std::uintmax_t max_bytes);

}  // namespace netkf
