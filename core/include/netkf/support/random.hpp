#pragma once
// Seeded, portable random streams. Every random stream in netkf is derived from
// the scenario seed with derive_seed(), so a run is reproducible; the generators
// below give the same numbers on every platform (std distributions do not).
//
// The per-draw paths are inline: the Monte Carlo kernels draw two or three numbers
// per filter step, so a call per draw would cost as much as the step itself.
#include <bit>
#include <cstdint>
#include <string_view>

namespace netkf {

/// splitmix64 step: used to mix seeds.
std::uint64_t splitmix64(std::uint64_t& state);

/// Seed for an independent stream: a hash of the scenario seed, a stream name
/// (e.g. "link", "sensor-noise", "process-noise") and an index (sensor id, run).
std::uint64_t derive_seed(std::uint64_t scenario_seed, std::string_view stream, std::uint64_t index = 0);

namespace detail {
/// The 256-layer normal ziggurat (Marsaglia & Tsang, J. Stat. Softw. 5(8), 2000):
/// layer i is the strip [0, x[i]] under exp(-x^2/2); x[1] = r is the start of the tail,
/// x[0] = v / f(r) the virtual width of the base strip, x[256] = 0.
struct NormalZiggurat {
  static constexpr int kLayers = 256;
  double x[kLayers + 1];
  double f[kLayers + 1];      // exp(-x^2 / 2)
  double ratio[kLayers];      // x[i+1] / x[i]: below it a draw is inside the strip's inner box
  NormalZiggurat();
};
/// The tables, built on first use (a function-local static: safe from any static initializer).
inline const NormalZiggurat& normal_ziggurat() {
  static const NormalZiggurat tables;
  return tables;
}
}  // namespace detail

/// xoshiro256++ generator with portable uniform and normal draws.
class Rng {
 public:
  explicit Rng(std::uint64_t seed = 0);

  std::uint64_t next_u64() {
    const std::uint64_t result = rotl(s_[0] + s_[3], 23) + s_[0];
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }

  /// Uniform in [0, 1) with 53 random bits (spacing 2^-53).
  double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }

  /// Standard normal by the ziggurat: one 64-bit word per draw in ~99% of cases
  /// (low 8 bits: layer, bit 8: sign, top 53 bits: position in the layer); the
  /// wedges and the tail (|z| > r = 3.654) take the exact slow path.
  double standard_normal() {
    const std::uint64_t bits = next_u64();
    const unsigned layer = static_cast<unsigned>(bits & 0xffu);
    const double position = static_cast<double>(bits >> 11) * 0x1.0p-53;
    const detail::NormalZiggurat& zig = detail::normal_ziggurat();
    const double z = position * zig.x[layer];
    if (position < zig.ratio[layer]) return with_sign_of_bit8(z, bits);
    return normal_slow_path(layer, z, (bits & 0x100u) != 0);
  }

 private:
  static constexpr std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  /// -z when bit 8 of `bits` is set, else z: moves that bit into the sign bit. A branch on a
  /// random bit would be mispredicted half the time.
  static double with_sign_of_bit8(double z, std::uint64_t bits) {
    return std::bit_cast<double>(std::bit_cast<std::uint64_t>(z) ^ ((bits & 0x100u) << 55));
  }
  double normal_slow_path(unsigned layer, double z, bool negative);

  std::uint64_t s_[4];
};

}  // namespace netkf
