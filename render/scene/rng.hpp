// Deterministic randomness for generators: SplitMix64 (same sequence on every platform,
// unlike <random>'s distributions) and a hashed 3-D value noise for displacements.
#pragma once
#include <cmath>
#include <cstdint>

#include "render/scene/geometry.hpp"

namespace rayline::scene {

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : s_(seed * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull) {}
  std::uint64_t next() {
    std::uint64_t z = (s_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  float uniform() { return float(next() >> 40) * (1.0f / 16777216.0f); }  // [0, 1)
  float uniform(float lo, float hi) { return lo + (hi - lo) * uniform(); }
  int below(int n) { return int(next() % std::uint64_t(n)); }  // [0, n)
  Float3 unit_vector() {  // uniform on the sphere
    const float z = uniform(-1, 1), a = uniform(0, 6.2831853f), r = std::sqrt(std::max(0.0f, 1 - z * z));
    return {r * std::cos(a), r * std::sin(a), z};
  }
  Rng fork(std::uint64_t stream) { return Rng(next() ^ (stream * 0xD1B54A32D192ED03ull)); }

 private:
  std::uint64_t s_;
};

// Value noise in [-1, 1]: hashed lattice values, smoothly interpolated.
inline float value_noise(Float3 p, std::uint64_t seed) {
  auto hash = [seed](std::int64_t x, std::int64_t y, std::int64_t z) {
    std::uint64_t h = seed ^ (std::uint64_t(x) * 0x8DA6B343ull) ^ (std::uint64_t(y) * 0xD8163841ull) ^
                      (std::uint64_t(z) * 0xCB1AB31Full);
    h = (h ^ (h >> 33)) * 0xFF51AFD7ED558CCDull;
    h = (h ^ (h >> 33)) * 0xC4CEB9FE1A85EC53ull;
    h ^= h >> 33;
    return float(h >> 40) * (2.0f / 16777216.0f) - 1.0f;
  };
  const float fx = std::floor(p.x), fy = std::floor(p.y), fz = std::floor(p.z);
  const auto ix = std::int64_t(fx), iy = std::int64_t(fy), iz = std::int64_t(fz);
  auto s = [](float t) { return t * t * (3 - 2 * t); };
  const float tx = s(p.x - fx), ty = s(p.y - fy), tz = s(p.z - fz);
  float c[2][2];
  for (int j = 0; j < 2; ++j)
    for (int k = 0; k < 2; ++k)
      c[j][k] = hash(ix, iy + j, iz + k) + (hash(ix + 1, iy + j, iz + k) - hash(ix, iy + j, iz + k)) * tx;
  const float a = c[0][0] + (c[1][0] - c[0][0]) * ty;
  const float b = c[0][1] + (c[1][1] - c[0][1]) * ty;
  return a + (b - a) * tz;
}

// Fractal sum of `octaves` value-noise layers, roughly in [-1, 1].
inline float fbm(Float3 p, int octaves, std::uint64_t seed) {
  float sum = 0, amp = 0.5f, norm = 0;
  for (int o = 0; o < octaves; ++o) {
    sum += amp * value_noise(p, seed + std::uint64_t(o));
    norm += amp;
    p = p * 2.03f;
    amp *= 0.5f;
  }
  return sum / norm;
}

}  // namespace rayline::scene
