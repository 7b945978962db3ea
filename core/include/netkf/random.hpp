#pragma once
// Seeded, portable random streams. Every random stream in netkf is derived from
// the scenario seed with derive_seed(), so a run is reproducible; the generators
// below give the same numbers on every platform (std distributions do not).
#include <cstdint>
#include <string_view>

namespace netkf {

/// splitmix64 step: used to mix seeds.
std::uint64_t splitmix64(std::uint64_t& state);

/// Seed for an independent stream: a hash of the scenario seed, a stream name
/// (e.g. "link", "sensor-noise", "process-noise") and an index (sensor id, run).
std::uint64_t derive_seed(std::uint64_t scenario_seed, std::string_view stream, std::uint64_t index = 0);

/// xoshiro256++ generator with portable uniform and normal draws.
class Rng {
 public:
  explicit Rng(std::uint64_t seed = 0);
  std::uint64_t next_u64();
  /// Uniform in [0, 1) with 53 random bits.
  double uniform();
  /// Standard normal (Marsaglia polar method; portable).
  double standard_normal();

 private:
  std::uint64_t s_[4];
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace netkf
