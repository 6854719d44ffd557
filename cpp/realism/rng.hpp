// lab/realism/rng.py in C++: the counter-based normal generator both layers draw from.
// Draw k of stream `seed` is SplitMix64's output on seed + (k + 1)·γ; normal i is Box–Muller's
// cosine branch on uniforms 2i and 2i + 1, so both kernels give the same numbers.
#pragma once

#include <cmath>
#include <cstdint>

namespace lab::realism {

constexpr std::uint64_t kGolden = 0x9E3779B97F4A7C15ULL;

/// SplitMix64's output function (Steele, Lea and Flood 2014).
inline std::uint64_t splitmix64(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

/// Draw `k` of stream `seed` as a double in [0, 1) (53 random bits).
inline double uniform(std::uint64_t seed, std::uint64_t k) {
  return static_cast<double>(splitmix64(seed + (k + 1) * kGolden) >> 11) * 0x1.0p-53;
}

/// Standard normal `i` of stream `seed`.
inline double normal(std::uint64_t seed, std::uint64_t i) {
  const double u1 = uniform(seed, 2 * i), u2 = uniform(seed, 2 * i + 1);
  return std::sqrt(-2.0 * std::log(1.0 - u1)) * std::cos(2.0 * M_PI * u2);
}

}  // namespace lab::realism
