#include "render/scene/builder.hpp"

#include <algorithm>
#include <cmath>

namespace rayline::scene {
namespace {
constexpr float kPi = 3.14159265358979f;

// Any unit vector perpendicular to d.
Float3 perpendicular(Float3 d) {
  const Float3 a = std::abs(d.x) < 0.9f ? Float3{1, 0, 0} : Float3{0, 1, 0};
  return normalize(cross(d, a));
}
}  // namespace

void MeshBuilder::grid(Float3 o, Float3 u, Float3 v, int nu, int nv) {
  const auto base = std::uint32_t(pos_.size());
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) vertex(o + u * (float(i) / nu) + v * (float(j) / nv));
  const auto row = std::uint32_t(nu + 1);
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const std::uint32_t a = base + std::uint32_t(j) * row + std::uint32_t(i);
      quad(a, a + 1, a + 1 + row, a + row);
    }
}

void MeshBuilder::box(const Affine& xf, int n) {
  // Six faces of [-1,1]^3, each outward-facing (u × v = outward normal).
  const Float3 P[6][3] = {
      {{1, -1, -1}, {0, 2, 0}, {0, 0, 2}},  {{-1, -1, -1}, {0, 0, 2}, {0, 2, 0}},
      {{-1, 1, -1}, {0, 0, 2}, {2, 0, 0}},  {{-1, -1, -1}, {2, 0, 0}, {0, 0, 2}},
      {{-1, -1, 1}, {2, 0, 0}, {0, 2, 0}},  {{-1, -1, -1}, {0, 2, 0}, {2, 0, 0}},
  };
  for (const auto& f : P) grid(xf.point(f[0]), xf.vector(f[1]), xf.vector(f[2]), n, n);
}

void MeshBuilder::tube(std::span<const Float3> path, float radius, int radial, bool caps, bool closed_loop) {
  const std::size_t n = path.size();
  if (n < 2 || radial < 3) return;
  const auto base = std::uint32_t(pos_.size());
  // Parallel-transport frames along the path.
  Float3 prev_t = normalize(path[1] - path[0]);
  Float3 nrm = perpendicular(prev_t);
  for (std::size_t i = 0; i < n; ++i) {
    Float3 t;
    if (closed_loop) t = normalize(path[(i + 1) % n] - path[(i + n - 1) % n]);
    else t = normalize(i == 0 ? path[1] - path[0] : i + 1 == n ? path[i] - path[i - 1] : path[i + 1] - path[i - 1]);
    nrm = normalize(nrm - t * dot(nrm, t));
    if (length(nrm) < 0.5f) nrm = perpendicular(t);
    const Float3 bin = cross(t, nrm);
    for (int k = 0; k < radial; ++k) {
      const float a = 2 * kPi * float(k) / float(radial);
      vertex(path[i] + (nrm * std::cos(a) + bin * std::sin(a)) * radius);
    }
    prev_t = t;
  }
  const auto R = std::uint32_t(radial);
  const std::size_t rings = closed_loop ? n : n - 1;
  for (std::size_t i = 0; i < rings; ++i) {
    const std::uint32_t r0 = base + std::uint32_t(i) * R, r1 = base + std::uint32_t((i + 1) % n) * R;
    for (std::uint32_t k = 0; k < R; ++k) quad(r0 + k, r0 + (k + 1) % R, r1 + (k + 1) % R, r1 + k);
  }
  if (caps && !closed_loop) {
    const std::uint32_t c0 = vertex(path[0]), c1 = vertex(path[n - 1]);
    const std::uint32_t last = base + std::uint32_t(n - 1) * R;
    for (std::uint32_t k = 0; k < R; ++k) {
      tri(c0, base + (k + 1) % R, base + k);
      tri(c1, last + k, last + (k + 1) % R);
    }
  }
}

void MeshBuilder::revolve(std::span<const std::pair<float, float>> profile, int radial, const Affine& xf) {
  const auto R = std::uint32_t(radial);
  std::vector<std::uint32_t> ring_start;  // first vertex of each ring; poles have one vertex
  std::vector<bool> pole;
  for (auto [r, h] : profile) {
    ring_start.push_back(std::uint32_t(pos_.size()));
    if (r <= 0) {
      pole.push_back(true);
      vertex(xf.point({0, h, 0}));
      continue;
    }
    pole.push_back(false);
    for (std::uint32_t k = 0; k < R; ++k) {
      const float a = 2 * kPi * float(k) / float(radial);
      vertex(xf.point({r * std::cos(a), h, r * std::sin(a)}));
    }
  }
  for (std::size_t i = 0; i + 1 < profile.size(); ++i) {
    const std::uint32_t a = ring_start[i], b = ring_start[i + 1];
    for (std::uint32_t k = 0; k < R; ++k) {
      const std::uint32_t k1 = (k + 1) % R;
      if (pole[i] && pole[i + 1]) break;
      if (pole[i]) tri(a, b + k, b + k1);
      else if (pole[i + 1]) tri(a + k, b, a + k1);
      else quad(a + k, b + k, b + k1, a + k1);
    }
  }
}

void MeshBuilder::arch(float r_in, float r_out, float depth, int n, const Affine& xf) {
  // Rings of 4 corners (inner front, outer front, outer back, inner back) over [0, π].
  const auto base = std::uint32_t(pos_.size());
  for (int i = 0; i <= n; ++i) {
    const float a = kPi * float(i) / float(n);
    const float c = std::cos(a), s = std::sin(a);
    vertex(xf.point({r_in * c, r_in * s, 0}));
    vertex(xf.point({r_out * c, r_out * s, 0}));
    vertex(xf.point({r_out * c, r_out * s, depth}));
    vertex(xf.point({r_in * c, r_in * s, depth}));
  }
  for (int i = 0; i < n; ++i) {
    const std::uint32_t p = base + std::uint32_t(i) * 4, q = p + 4;
    for (std::uint32_t k = 0; k < 4; ++k) quad(p + k, q + k, q + (k + 1) % 4, p + (k + 1) % 4);
  }
  const std::uint32_t e = base + std::uint32_t(n) * 4;
  quad(base, base + 3, base + 2, base + 1);
  quad(e, e + 1, e + 2, e + 3);
}

void MeshBuilder::exact_patch(std::uint64_t count, Float3 o, Float3 u, Float3 v) {
  if (count == 0) return;
  // nu × nv full rows of quads, then one strip row of `last` triangles (bottom and top
  // edges split into different numbers of segments); the rows tile the whole rectangle.
  const std::uint64_t quads = count / 2;
  std::uint64_t nu = std::max<std::uint64_t>(1, std::uint64_t(std::sqrt(double(std::max<std::uint64_t>(quads, 1)))));
  std::uint64_t nv = quads / nu;
  std::uint64_t last = 2 * (quads - nu * nv) + count % 2;
  if (last == 1 && nv > 0) last += 2 * nu, --nv;
  const std::uint64_t rows = nv + (last > 0 ? 1 : 0);
  const Float3 dv = v * (1.0f / float(rows));
  if (nv > 0) grid(o, u, dv * float(nv), int(nu), int(nv));
  if (last == 0) return;
  const Float3 row = o + dv * float(nv);
  const std::uint64_t m = (last + 1) / 2, n = last / 2;  // bottom / top segments, m + n = last
  const auto b0 = std::uint32_t(pos_.size());
  for (std::uint64_t i = 0; i <= m; ++i) vertex(row + u * (float(i) / float(m)));
  const auto t0 = std::uint32_t(pos_.size());
  if (n == 0) vertex(row + dv + u * 0.5f);
  for (std::uint64_t j = 0; n > 0 && j <= n; ++j) vertex(row + dv + u * (float(j) / float(n)));
  std::uint64_t i = 0, j = 0;
  while (i < m || j < n) {
    const bool advance_bottom = j == n || (i < m && double(i + 1) / double(m) <= double(j + 1) / double(n));
    if (advance_bottom) tri(b0 + std::uint32_t(i), b0 + std::uint32_t(i + 1), t0 + std::uint32_t(j)), ++i;
    else tri(b0 + std::uint32_t(i), t0 + std::uint32_t(j + 1), t0 + std::uint32_t(j)), ++j;
  }
}

void MeshBuilder::cube_sphere_tile(int face, int g, int i0, int i1, int j0, int j1,
                                   const std::function<Float3(Float3)>& shape) {
  // Face frames {normal axis, u axis, v axis} with u × v pointing outward (even faces +, odd −).
  static const int axes[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 2, 0}, {1, 0, 2}, {2, 0, 1}, {2, 1, 0}};
  const int n = axes[face][0], a = axes[face][1], b = axes[face][2];
  const float sgn = face % 2 == 0 ? 1.0f : -1.0f;
  const auto base = std::uint32_t(pos_.size());
  // Lattice coordinate (2i - g) / g is exact for shared edges of neighbouring faces.
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) {
      Float3 c;
      c[n] = sgn;
      c[a] = float(2 * i - g) / float(g);
      c[b] = float(2 * j - g) / float(g);
      vertex(shape(normalize(c)));
    }
  const auto row = std::uint32_t(i1 - i0 + 1);
  for (int j = 0; j < j1 - j0; ++j)
    for (int i = 0; i < i1 - i0; ++i) {
      const std::uint32_t p = base + std::uint32_t(j) * row + std::uint32_t(i);
      quad(p, p + 1, p + 1 + row, p + row);
    }
}

void MeshBuilder::flush(MeshSink& sink, std::uint16_t material) {
  if (!tris_.empty()) sink.add(MeshPiece{pos_, tris_, material});
  clear();
}

std::uint64_t emit_cube_sphere(MeshSink& sink, std::uint64_t triangles, std::uint16_t material,
                               const std::function<Float3(Float3)>& shape, int tile) {
  const int g = std::max(1, int(std::sqrt(double(triangles) / 12.0)));
  MeshBuilder mb;
  std::uint64_t emitted = 0;
  for (int face = 0; face < 6; ++face)
    for (int j0 = 0; j0 < g; j0 += tile)
      for (int i0 = 0; i0 < g; i0 += tile) {
        mb.cube_sphere_tile(face, g, i0, std::min(g, i0 + tile), j0, std::min(g, j0 + tile), shape);
        emitted += mb.triangle_count();
        mb.flush(sink, material);
      }
  return emitted;
}

int quadratic_detail_level(const std::function<std::uint64_t(int)>& count, double fraction, std::uint64_t triangles) {
  const double c1 = double(count(1)), c2 = double(count(2)), c3 = double(count(3));
  const double a = (c3 - 2 * c2 + c1) / 2, b = c2 - c1 - 3 * a, c = c1 - a - b;
  const double target = fraction * double(triangles);
  if (target <= c1) return 1;
  return std::max(1, int((-b + std::sqrt(b * b - 4 * a * (c - target))) / (2 * a)));
}

}  // namespace rayline::scene
