#pragma once
// Small texts and identifiers the commands print or send.
#include <cstdint>
#include <string>

namespace netkf::cli {

/// "8", "2.5", "1e+03": a number as a person writes it.
std::string number_text(double v);
/// A 64-bit id as 16 hex digits ("00ab..."), as run ids are shown everywhere.
std::string hex_id(std::uint64_t id);

/// 128 random bits as hex, from the kernel's random source: the dashboard's token when it
/// listens beyond 127.0.0.1. Not part of any experiment (never seeded from a scenario).
std::string random_token();
/// A nonzero 64-bit id from the kernel's random source: a whole network's run id.
std::uint64_t random_run_id();
/// A positive 63-bit id unlikely to collide with another process's: a link change request.
std::uint64_t random_request_id();

}  // namespace netkf::cli
