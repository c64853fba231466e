// Small geometry vocabulary of the scene library: Float3, Bounds, Affine (3x4 row-major).
// Header-only and dependency-free so the renderer's hot loops can use it as is.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace rayline::scene {

struct Float3 {
  float x = 0, y = 0, z = 0;
  float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  float& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  friend bool operator==(const Float3&, const Float3&) = default;
};
inline Float3 operator+(Float3 a, Float3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Float3 operator-(Float3 a, Float3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Float3 operator*(Float3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
inline Float3 operator*(float s, Float3 a) { return a * s; }
inline float dot(Float3 a, Float3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Float3 cross(Float3 a, Float3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length(Float3 a) { return std::sqrt(dot(a, a)); }
inline Float3 normalize(Float3 a) {
  const float l = length(a);
  return l > 0 ? a * (1.0f / l) : Float3{0, 0, 0};
}
inline Float3 lerp(Float3 a, Float3 b, float t) { return a + (b - a) * t; }

struct Bounds {
  Float3 lo{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
            std::numeric_limits<float>::infinity()};
  Float3 hi{-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
            -std::numeric_limits<float>::infinity()};
  bool empty() const { return !(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z); }
  void extend(Float3 p) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  void extend(const Bounds& b) {
    if (!b.empty()) { extend(b.lo); extend(b.hi); }
  }
  Float3 center() const { return (lo + hi) * 0.5f; }
  Float3 extent() const { return hi - lo; }
};

// Affine map p' = M p + t stored as 3 rows of (m0 m1 m2 t).
struct Affine {
  float m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
  Float3 point(Float3 p) const {
    return {m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
            m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
            m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3]};
  }
  Float3 vector(Float3 v) const {
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z, m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
  }
  bool is_identity() const { return *this == Affine{}; }
  friend bool operator==(const Affine& a, const Affine& b) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        if (a.m[r][c] != b.m[r][c]) return false;
    return true;
  }
  // this ∘ o (apply o first).
  Affine operator*(const Affine& o) const {
    Affine r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j) {
        float s = j == 3 ? m[i][3] : 0.0f;
        for (int k = 0; k < 3; ++k) s += m[i][k] * o.m[k][j];
        r.m[i][j] = s;
      }
    return r;
  }
  static Affine translate(Float3 t) {
    Affine a;
    a.m[0][3] = t.x, a.m[1][3] = t.y, a.m[2][3] = t.z;
    return a;
  }
  static Affine scale(Float3 s) {
    Affine a;
    a.m[0][0] = s.x, a.m[1][1] = s.y, a.m[2][2] = s.z;
    return a;
  }
  // Rotation by `deg` degrees about `axis` (right-handed).
  static Affine rotate(Float3 axis, float deg) {
    const Float3 u = normalize(axis);
    const double r = double(deg) * 3.14159265358979323846 / 180.0;
    const float c = float(std::cos(r)), s = float(std::sin(r)), t = 1 - c;
    Affine a;
    a.m[0][0] = t * u.x * u.x + c, a.m[0][1] = t * u.x * u.y - s * u.z, a.m[0][2] = t * u.x * u.z + s * u.y;
    a.m[1][0] = t * u.x * u.y + s * u.z, a.m[1][1] = t * u.y * u.y + c, a.m[1][2] = t * u.y * u.z - s * u.x;
    a.m[2][0] = t * u.x * u.z - s * u.y, a.m[2][1] = t * u.y * u.z + s * u.x, a.m[2][2] = t * u.z * u.z + c;
    return a;
  }
  // Maps x,y,z unit axes onto the given orthonormal frame, then translates to origin.
  static Affine frame(Float3 x, Float3 y, Float3 z, Float3 origin) {
    Affine a;
    for (int r = 0; r < 3; ++r) a.m[r][0] = x[r], a.m[r][1] = y[r], a.m[r][2] = z[r], a.m[r][3] = origin[r];
    return a;
  }
};

}  // namespace rayline::scene
