#pragma once
// The files a command writes where its user says (-o, --out, --record, --summary, --plot, ...):
// one policy for all of them (docs/cli.md, "Output files").
// - Only a regular file is written: an output that exists as a device, a FIFO, a socket or a
//   directory (or a symbolic link to nothing) is refused, exit 2, and left as it is.
// - A command never removes a file it did not create.
// - Two outputs of one command, or an output and an input, may not be one file (however the
//   path is spelled, through a symbolic link or a hard link): refused before any is opened.
// - A file written whole at once goes to a temporary file beside it that is renamed over it:
//   a failed write (a full disk) leaves the old file as it was.
// Every refusal and every write error is a CommandError (bad_usage) naming the file and why.
#include <memory>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

namespace netkf::cli {

/// A file named on the command line, and the option (or argument) that named it.
struct FileArg {
  std::string option;  // "--record", "-o", "the scenario"
  std::string path;
};

/// Refuses an output that cannot be a regular file written here: an empty path, a directory
/// that does not exist, an existing file that is not a regular file (by its kind), a symbolic
/// link to nothing.
void check_output_path(const FileArg& output);

/// check_output_path for each output, then refuses two outputs, or an output and an input,
/// that are one file. Call it before any of them is opened.
void check_output_files(const std::vector<FileArg>& outputs, const std::vector<FileArg>& inputs = {});

/// Refuses outputs that exist (a recording is a run that cannot be made again): "PATH
/// (OPTION) exists: `how_to_replace` to replace it".
void refuse_existing(const std::vector<FileArg>& outputs, std::string_view how_to_replace);

/// A file written as a command runs (a recording): created, or a regular file emptied;
/// checked on the open file itself, so a device put in its place is never written or
/// truncated. The stream's write errors are the caller's to check (errno says why).
std::unique_ptr<std::ostream> open_output_stream(const FileArg& output);

/// Writes `text` as the file `output.path`, whole: into a temporary file beside it (beside
/// the file a symbolic link points to), then renamed over it (an existing file keeps its
/// mode). A failed write removes the temporary file and leaves `output.path` as it was.
/// `sync`: the temporary file is flushed to the disk before the rename (fsync: a write error
/// the system reports late is seen, and a crash leaves the old file or the new one); false
/// for a file rewritten during a run (the journal), whose loop must not wait for the disk.
void write_output_file(const FileArg& output, std::string_view text, bool sync = true);

}  // namespace netkf::cli
