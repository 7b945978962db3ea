#include "launch_files.hpp"

#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>

namespace netkf::cli {

namespace fs = std::filesystem;

fs::path launch_files_base() {
  if (const char* runtime = std::getenv("XDG_RUNTIME_DIR"); runtime && *runtime && fs::is_directory(runtime))
    return fs::path(runtime) / "netkf";
  return fs::temp_directory_path() / ("netkf-" + std::to_string(getuid()));
}

std::optional<unsigned long long> process_start_time(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat;
  if (!in || !std::getline(in, stat)) return std::nullopt;
  // The command name (field 2) may hold spaces and parentheses: fields 3.. follow the last ')'.
  const auto close = stat.rfind(')');
  if (close == std::string::npos) return std::nullopt;
  std::istringstream fields(stat.substr(close + 1));
  std::string field;
  for (int i = 3; i <= 22; ++i) {
    if (!(fields >> field)) return std::nullopt;
    if (i == 22) {
      try {
        return std::stoull(field);
      } catch (const std::exception&) {
        return std::nullopt;
      }
    }
  }
  return std::nullopt;
}

namespace {

// launch-<pid>-<start time>: running iff that pid runs with that start time (a pid reused by
// another process after a reboot or wrap-around does not keep a dead launch's files).
bool owner_running(const std::string& name) {
  static const std::regex pattern(R"(launch-(\d+)-(\d+))");
  std::smatch m;
  if (!std::regex_match(name, m, pattern)) return true;  // not ours: leave it alone
  try {
    const auto pid = static_cast<pid_t>(std::stol(m[1].str()));
    const auto start = process_start_time(pid);
    return start && std::to_string(*start) == m[2].str();
  } catch (const std::exception&) {
    return true;
  }
}

}  // namespace

LaunchFiles::LaunchFiles(const fs::path& base) {
  std::error_code ec;
  fs::create_directories(base, ec);
  if (ec) throw std::runtime_error("cannot create " + base.string() + ": " + ec.message());
  // Private: another user must not read the scenario or plant a checkpoint.
  fs::permissions(base, fs::perms::owner_all, fs::perm_options::replace, ec);
  struct stat st {};
  if (::stat(base.c_str(), &st) != 0 || st.st_uid != getuid())
    throw std::runtime_error(base.string() + " is not owned by this user: refusing to keep the launch's files there");
  for (const auto& entry : fs::directory_iterator(base, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("launch-", 0) != 0 || owner_running(name)) continue;
    std::error_code remove_ec;
    fs::remove_all(entry.path(), remove_ec);
    if (!remove_ec) removed_stale_.push_back(entry.path());
  }
  const auto start = process_start_time(getpid());
  dir_ = base / ("launch-" + std::to_string(getpid()) + "-" + std::to_string(start.value_or(0)));
  fs::remove_all(dir_, ec);
  if (!fs::create_directory(dir_, ec) || ec)
    throw std::runtime_error("cannot create " + dir_.string() + ": " + (ec ? ec.message() : "exists"));
  fs::permissions(dir_, fs::perms::owner_all, fs::perm_options::replace, ec);
}

LaunchFiles::~LaunchFiles() {
  std::error_code ec;
  fs::remove_all(dir_, ec);
}

SharedMemoryClean parse_shm_clean_report(const std::string& text) {
  SharedMemoryClean r;
  std::smatch m;
  static const std::regex ports(R"((\d+) zombie ports cleaned)");
  static const std::regex segments(R"((\d+) zombie segments cleaned)");
  if (std::regex_search(text, m, ports)) {
    r.zombie_ports = std::stoi(m[1].str());
    r.ran = true;
  }
  if (std::regex_search(text, m, segments)) {
    r.zombie_segments = std::stoi(m[1].str());
    r.ran = true;
  }
  return r;
}

SharedMemoryClean clean_stale_shared_memory() {
  // The tool is Python (Debian's fastdds-tools); its report goes to stdout.
  FILE* pipe = ::popen("fastdds shm clean 2>/dev/null", "r");
  if (!pipe) return {};
  std::string text;
  std::array<char, 256> buffer{};
  while (std::fgets(buffer.data(), static_cast<int>(buffer.size()), pipe)) text += buffer.data();
  const int status = ::pclose(pipe);
  if (status != 0) return {};
  return parse_shm_clean_report(text);
}

}  // namespace netkf::cli
