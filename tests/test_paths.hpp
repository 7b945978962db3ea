#pragma once
// Where the tests find the repository's files: from the environment that CTest sets
// (tests/CMakeLists.txt), else the checkout that holds the test executable (the presets
// build in <checkout>/build/<preset>; CTest's test discovery runs without the
// environment). No path is compiled in, so the compiled tests are the same in every
// checkout and ccache hits across clones.
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace netkf::test {

/// The repository's root.
inline std::filesystem::path source_dir() {
  if (const char* value = std::getenv("NETKF_SOURCE_DIR"); value && *value) return value;
  std::error_code ec;
  auto dir = std::filesystem::read_symlink("/proc/self/exe", ec).parent_path();
  for (; !ec && !dir.empty() && dir != dir.root_path(); dir = dir.parent_path())
    if (std::filesystem::exists(dir / "tests" / "data") && std::filesystem::exists(dir / "CMakeLists.txt")) return dir;
  throw std::runtime_error("cannot find the netkf checkout: set NETKF_SOURCE_DIR (ctest does)");
}
/// tests/data.
inline std::filesystem::path test_data_dir() { return source_dir() / "tests" / "data"; }

}  // namespace netkf::test
