// MeshBuilder: a small indexed mesh assembled from primitives, then flushed to a
// MeshSink as one MeshPiece. Generators keep pieces small (≤ a few hundred thousand
// triangles) so memory stays bounded whatever the scene size.
#pragma once
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "render/scene/mesh_sink.hpp"

namespace rayline::scene {

// Generators size their fixed parts with a detail level q whose triangle count grows
// quadratically: fit count(q) = a q^2 + b q + c from q = 1, 2, 3 and return the largest q
// whose count stays within `fraction` of `triangles` (at least 1).
int quadratic_detail_level(const std::function<std::uint64_t(int)>& count, double fraction, std::uint64_t triangles);

class MeshBuilder {
 public:
  std::uint32_t vertex(Float3 p) {
    pos_.push_back(p);
    return std::uint32_t(pos_.size() - 1);
  }
  void tri(std::uint32_t a, std::uint32_t b, std::uint32_t c) { tris_.push_back({a, b, c}); }
  void quad(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) { tri(a, b, c), tri(a, c, d); }

  // Flat nu × nv grid over origin + s·u + t·v (2·nu·nv triangles, facing u × v).
  void grid(Float3 origin, Float3 u, Float3 v, int nu, int nv);
  // Closed box: the cube [-1, 1]^3 mapped by `xf`, each face an n × n grid.
  void box(const Affine& xf, int n = 1);
  // A tube of `radius` swept along `path` (≥ 2 points) with `radial` sides; `closed_loop`
  // joins the last ring to the first (torus), otherwise `caps` closes the ends.
  void tube(std::span<const Float3> path, float radius, int radial, bool caps, bool closed_loop = false);
  // Surface of revolution about the local y axis of `xf`: profile (radius, height) pairs,
  // `radial` sides; a profile point with radius 0 becomes a pole (closed ends).
  void revolve(std::span<const std::pair<float, float>> profile, int radial, const Affine& xf);
  // Closed half-ring (arch): inner/outer radius in the local xy plane, depth along z,
  // `n` segments over the half circle, mapped by `xf`.
  void arch(float r_in, float r_out, float depth, int n, const Affine& xf);
  // Exactly `count` triangles tiling the parallelogram origin + s·u + t·v.
  void exact_patch(std::uint64_t count, Float3 origin, Float3 u, Float3 v);
  // Displaced cube-sphere tile: face `face` of a cube subdivided g × g, rows/cols
  // [i0, i1) × [j0, j1); `shape` maps a unit-sphere direction to a position. Vertices
  // on shared edges are computed from the same lattice point, so tiles meet exactly.
  void cube_sphere_tile(int face, int g, int i0, int i1, int j0, int j1,
                        const std::function<Float3(Float3)>& shape);

  std::size_t triangle_count() const { return tris_.size(); }
  std::size_t vertex_count() const { return pos_.size(); }
  bool empty() const { return tris_.empty(); }
  void flush(MeshSink& sink, std::uint16_t material);  // emits one piece, then clears
  void clear() { pos_.clear(), tris_.clear(); }

 private:
  std::vector<Float3> pos_;
  std::vector<Tri> tris_;
};

// Streams a closed displaced cube sphere with about `triangles` triangles (12·g², g ≥ 1)
// in tiles of at most `tile`×`tile` quads. Returns the triangles emitted.
std::uint64_t emit_cube_sphere(MeshSink& sink, std::uint64_t triangles, std::uint16_t material,
                               const std::function<Float3(Float3)>& shape, int tile = 256);

}  // namespace rayline::scene
