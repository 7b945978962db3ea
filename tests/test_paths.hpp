#pragma once
// Where the tests find the repository's files: from the environment that CTest sets
// (tests/CMakeLists.txt), not from paths compiled in, so that the compiled tests are the
// same in every checkout and ccache hits across clones.
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace netkf::test {

inline std::filesystem::path env_dir(const char* name) {
  const char* value = std::getenv(name);
  if (!value || !*value) throw std::runtime_error(std::string(name) + " is not set (run the tests through ctest)");
  return value;
}
/// The repository's root.
inline std::filesystem::path source_dir() { return env_dir("NETKF_SOURCE_DIR"); }
/// tests/data.
inline std::filesystem::path test_data_dir() { return source_dir() / "tests" / "data"; }

}  // namespace netkf::test
