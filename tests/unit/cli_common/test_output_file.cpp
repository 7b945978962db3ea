// The output files' policy (output_file.hpp), on real files: FIFOs and, where this process
// may make them (root: mknod), character devices like /dev/null and /dev/full.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "netkf/cli/common/exit_code.hpp"
#include "netkf/cli/common/output_file.hpp"

namespace netkf::cli {
namespace {

namespace fs = std::filesystem;

class OutputFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("netkf-output-files-" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  static std::string read(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }
  static void write(const std::string& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }
  /// A character device with /dev/null's (1, 3) or /dev/full's (1, 7) numbers; false when this
  /// process may not make one.
  static bool make_char_device(const std::string& p, unsigned minor) {
    return ::mknod(p.c_str(), S_IFCHR | 0666, makedev(1, minor)) == 0;
  }
  /// The files of the directory (a temporary file left behind would be one).
  std::vector<std::string> entries() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }
  static ExitCode code_of(const std::function<void()>& f) {
    try {
      f();
    } catch (const CommandError& e) {
      return e.code();
    }
    return ExitCode::ok;
  }
  static std::string message_of(const std::function<void()>& f) {
    try {
      f();
    } catch (const CommandError& e) {
      return e.what();
    }
    return {};
  }

  fs::path dir_;
};

TEST_F(OutputFiles, WriteReplacesARegularFileWholeKeepingItsMode) {
  const std::string out = path("copy.yaml");
  write(out, "old text that is longer than the new one\n");
  ::chmod(out.c_str(), 0640);
  write_output_file({"-o", out}, "new\n");
  EXPECT_EQ(read(out), "new\n");
  struct stat st {};
  ASSERT_EQ(::stat(out.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0640u);
  EXPECT_EQ(entries(), std::vector<std::string>{"copy.yaml"});  // no temporary file left
  // A new file.
  write_output_file({"-o", path("new.csv")}, "k,delivered\n");
  EXPECT_EQ(read(path("new.csv")), "k,delivered\n");
}

TEST_F(OutputFiles, WriteThroughASymlinkReplacesItsTargetAndKeepsTheLink) {
  fs::create_directories(dir_ / "real");
  write(path("real/target.csv"), "old\n");
  fs::create_symlink(dir_ / "real" / "target.csv", dir_ / "link.csv");
  write_output_file({"-o", path("link.csv")}, "new\n");
  EXPECT_TRUE(fs::is_symlink(dir_ / "link.csv"));
  EXPECT_EQ(read(path("real/target.csv")), "new\n");
}

TEST_F(OutputFiles, NonRegularTargetsAreRefusedAndLeftInPlace) {
  const std::string fifo = path("fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  EXPECT_EQ(code_of([&] { write_output_file({"-o", fifo}, "x\n"); }), ExitCode::bad_usage);
  EXPECT_EQ(code_of([&] { open_output_stream({"--record", fifo}); }), ExitCode::bad_usage);  // and no wait for a reader
  EXPECT_THAT(message_of([&] { check_output_path({"--record", fifo}); }), ::testing::HasSubstr("FIFO"));
  EXPECT_TRUE(fs::is_fifo(fifo));
  EXPECT_EQ(code_of([&] { write_output_file({"-o", dir_.string()}, "x\n"); }), ExitCode::bad_usage);
  // A symbolic link to nothing is not followed into a new file.
  fs::create_symlink(dir_ / "missing", dir_ / "dangling");
  EXPECT_EQ(code_of([&] { write_output_file({"-o", path("dangling")}, "x\n"); }), ExitCode::bad_usage);
  EXPECT_FALSE(fs::exists(dir_ / "missing"));
  // A directory that does not exist.
  EXPECT_THAT(message_of([&] { check_output_path({"--summary", path("no-dir/s.json")}); }),
              ::testing::HasSubstr("does not exist"));
  EXPECT_EQ(code_of([&] { check_output_path({"-o", ""}); }), ExitCode::bad_usage);

  const std::string null_copy = path("null"), full_copy = path("full");
  if (!make_char_device(null_copy, 3) || !make_char_device(full_copy, 7)) GTEST_SKIP() << "mknod is not allowed here";
  for (const auto& device : {null_copy, full_copy}) {
    SCOPED_TRACE(device);
    EXPECT_THAT(message_of([&] { write_output_file({"-o", device}, "x\n"); }),
                ::testing::HasSubstr("is a character device, not a regular file"));
    EXPECT_EQ(code_of([&] { open_output_stream({"--record", device}); }), ExitCode::bad_usage);
    struct stat st {};
    ASSERT_EQ(::lstat(device.c_str(), &st), 0);  // still there, still the device
    EXPECT_TRUE(S_ISCHR(st.st_mode));
  }
}

TEST_F(OutputFiles, AStreamEmptiesARegularFileAndReportsWriteErrors) {
  const std::string out = path("run.csv");
  write(out, "an earlier run's rows\n");
  {
    auto s = open_output_stream({"--record", out});
    *s << "k,t\n";
    s->flush();
    EXPECT_TRUE(s->good());
  }
  EXPECT_EQ(read(out), "k,t\n");
  // A write the file system refuses (here: the file size limit) is seen on the stream.
  struct rlimit old {};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto old_handler = ::signal(SIGXFSZ, SIG_IGN);
  struct rlimit small = old;
  small.rlim_cur = 4096;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  auto s = open_output_stream({"--record", out});
  *s << std::string(8192, 'x');
  s->flush();
  const bool failed = !s->good();
  // write_output_file: the same limit is a clear error, and the old file stays as it was.
  const std::string kept = path("kept.csv");
  write(kept, "kept\n");
  const std::string message = message_of([&] { write_output_file({"-o", kept}, std::string(8192, 'y')); });
  ::setrlimit(RLIMIT_FSIZE, &old);
  ::signal(SIGXFSZ, old_handler);
  EXPECT_TRUE(failed);
  EXPECT_THAT(message, ::testing::HasSubstr("cannot write " + kept + " (-o): File too large"));
  EXPECT_EQ(read(kept), "kept\n");
  s.reset();
  std::vector<std::string> left = entries();
  EXPECT_EQ(left, (std::vector<std::string>{"kept.csv", "run.csv"}));  // the temporary file removed
}

TEST_F(OutputFiles, TwoOutputsOnOneFileAreRefusedHoweverNamed) {
  write(path("same.csv"), "x\n");
  fs::create_symlink(dir_ / "same.csv", dir_ / "alias.csv");
  fs::create_hard_link(dir_ / "same.csv", dir_ / "hard.csv");
  fs::create_directories(dir_ / "sub");
  const std::string a = path("same.csv");
  for (const std::string& b : {a, path("./same.csv"), path("sub/../same.csv"), path("alias.csv"), path("hard.csv")}) {
    SCOPED_TRACE(b);
    EXPECT_THAT(message_of([&] { check_output_files({{"--record", a}, {"--record-samples", b}}); }),
                ::testing::HasSubstr("are one file"));
  }
  // Files that do not exist yet: by their path.
  EXPECT_EQ(code_of([&] { check_output_files({{"--record", path("n.csv")}, {"--summary", path("sub/../n.csv")}}); }),
            ExitCode::bad_usage);
  EXPECT_EQ(code_of([&] { check_output_files({{"--record", path("n.csv")}, {"--record-samples", path("m.csv")}}); }),
            ExitCode::ok);
  // An output that is an input.
  EXPECT_THAT(message_of([&] { check_output_files({{"-o", path("alias.csv")}}, {{"the recording", a}}); }),
              ::testing::HasSubstr("an output may not overwrite an input"));
  // Nothing was touched.
  EXPECT_EQ(read(a), "x\n");
}

TEST_F(OutputFiles, ExistingRecordingsAreRefusedUntilForced) {
  write(path("run.csv"), "a run\n");
  EXPECT_THAT(message_of([&] { refuse_existing({{"--record", path("run.csv")}}, "give --force"); }),
              ::testing::HasSubstr("exists: give --force to replace it"));
  EXPECT_EQ(code_of([&] { refuse_existing({{"--record", path("other.csv")}}, "give --force"); }), ExitCode::ok);
  EXPECT_EQ(read(path("run.csv")), "a run\n");
}

}  // namespace
}  // namespace netkf::cli
