#pragma once
// SHA-256 (FIPS 180-4) of a byte string, as 64 lowercase hex digits: the scenario's hash in
// sweep.yaml, so `--resume` can tell that the scenario file changed under a cut sweep.
#include <string>
#include <string_view>

namespace netkf::cli::sweep {

std::string sha256_hex(std::string_view data);

}  // namespace netkf::cli::sweep
