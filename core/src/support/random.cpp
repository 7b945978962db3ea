// Seeded, portable random streams (netkf/support/random.hpp).
// xoshiro256++ and splitmix64 are Blackman & Vigna's generators
// (https://prng.di.unimi.it/); the normal draw is Marsaglia & Tsang's ziggurat, whose
// tables and slow paths need only exp, log, sqrt and erfc, so every platform gives the same
// numbers (std::normal_distribution is implementation-defined).
#include "netkf/support/random.hpp"

#include <cmath>

namespace netkf {
namespace {

// FNV-1a (64 bit) of the stream name: a fixed, portable string hash
// (std::hash is implementation-defined).
std::uint64_t fnv1a(std::string_view text) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (const char c : text) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;
  }
  return h;
}

// Marsaglia & Tsang (2000), 256 strips: r = start of the tail, chosen so that 256 strips of
// equal area close at the top.
constexpr double kTailStart = 3.6541528853610088;

double density(double x) { return std::exp(-0.5 * x * x); }

// Area of each strip: that of the base strip, the box [0, r] x [0, f(r)] plus the tail
// integral sqrt(pi/2) erfc(r / sqrt 2) (the paper's 4.92867323399e-3, to full precision).
double strip_area() {
  return kTailStart * density(kTailStart) + std::sqrt(std::acos(-1.0) / 2.0) * std::erfc(kTailStart / std::sqrt(2.0));
}

}  // namespace

namespace detail {

NormalZiggurat::NormalZiggurat() {
  const double v = strip_area();
  x[0] = v / density(kTailStart);
  x[1] = kTailStart;
  // Strip i has area x[i] (f(x[i+1]) - f(x[i])) = v, solved for x[i+1].
  for (int i = 1; i < kLayers - 1; ++i) x[i + 1] = std::sqrt(-2.0 * std::log(v / x[i] + density(x[i])));
  x[kLayers] = 0.0;
  for (int i = 0; i <= kLayers; ++i) f[i] = density(x[i]);
  f[0] = 0.0;  // unused: a draw in layer 0 outside its box goes to the tail, not to a wedge
  for (int i = 0; i < kLayers; ++i) ratio[i] = x[i + 1] / x[i];
}

}  // namespace detail

std::uint64_t splitmix64(std::uint64_t& state) {
  state += 0x9e3779b97f4a7c15ULL;
  std::uint64_t z = state;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

std::uint64_t derive_seed(std::uint64_t scenario_seed, std::string_view stream, std::uint64_t index) {
  // Chain the three inputs through splitmix64 so that every one of them changes
  // every output bit: seed, then the stream name's hash, then the index.
  std::uint64_t state = scenario_seed;
  state = splitmix64(state) ^ fnv1a(stream);
  state = splitmix64(state) ^ index;
  return splitmix64(state);
}

Rng::Rng(std::uint64_t seed) {
  // The xoshiro authors' recommended seeding: four splitmix64 outputs, which are
  // never all zero (splitmix64 is a bijection of a counter).
  std::uint64_t state = seed;
  for (auto& word : s_) word = splitmix64(state);
}

double Rng::normal_slow_path(unsigned layer, double z, bool negative) {
  if (layer == 0) {
    // Beyond the base box: the tail |z| > r (Marsaglia 1964). 1 - uniform() is in (0, 1].
    double t = 0.0;
    double e = 0.0;
    do {
      t = -std::log(1.0 - uniform()) / kTailStart;
      e = -std::log(1.0 - uniform());
    } while (e + e < t * t);
    return negative ? -(kTailStart + t) : kTailStart + t;
  }
  // In the wedge between the inner box and the density: accept under exp(-z^2/2).
  const auto& zig = detail::normal_ziggurat();
  if (zig.f[layer] + uniform() * (zig.f[layer + 1] - zig.f[layer]) < density(z)) return negative ? -z : z;
  // Rejected (about 1 draw in 100): a fresh draw. Another rejection in a row is as rare again,
  // so the recursion stays shallow.
  return standard_normal();
}

}  // namespace netkf
