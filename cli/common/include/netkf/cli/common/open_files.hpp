#pragma once
// The process's limit of open files (RLIMIT_NOFILE). A launch holds DDS sockets, a pipe per
// child it starts and the dashboard's connections: it raises its soft limit to the hard one at
// start, and the dashboard keeps its connection cap far below it (docs/dashboard.md, "Limits").
#include <cstdint>

namespace netkf::cli {

/// Raise the soft limit of open files to the hard limit; returns the soft limit now in force
/// (the old one when it could not be raised).
std::uint64_t raise_open_file_limit();

}  // namespace netkf::cli
