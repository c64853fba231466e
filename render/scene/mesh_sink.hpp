// How triangles flow through the scene library without ever being held all at once.
//  * Producers (generators, importers) hand indexed MeshPieces to a MeshSink.
//  * Consumers that want a plain triangle soup (partitioner, BVH builder) receive
//    TriangleBatches through a callback (see scene_stream.hpp, ply_reader.hpp).
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "render/scene/geometry.hpp"

namespace rayline::scene {

using Tri = std::array<std::uint32_t, 3>;  // vertex indices, local to their piece

// A small indexed mesh: indices refer to `positions` of the same piece. `material` is
// the slot number inside its mesh file (PLY face property `material_index`).
struct MeshPiece {
  std::span<const Float3> positions;
  std::span<const Tri> triangles;
  std::uint16_t material = 0;
};

class MeshSink {
 public:
  virtual ~MeshSink() = default;
  virtual void add(const MeshPiece& piece) = 0;
};

// One triangle of a soup, in world space. `material` is a scene material index when it
// comes from scene_stream, a mesh-local slot when it comes from a mesh file reader.
struct Triangle {
  Float3 v0, v1, v2;
  std::uint32_t material = 0;
};
using TriangleBatchFn = std::function<void(std::span<const Triangle>)>;

// Adapts a MeshSink producer to a triangle-batch consumer (batches of `batch` triangles).
class TriangleBatcher final : public MeshSink {
 public:
  explicit TriangleBatcher(TriangleBatchFn fn, std::size_t batch = 1 << 16) : fn_(std::move(fn)), batch_(batch) {
    buf_.reserve(batch_);
  }
  ~TriangleBatcher() override = default;
  // Maps piece material slots to output ids (empty: identity).
  void set_material_map(std::vector<std::uint32_t> map) { map_ = std::move(map); }
  void set_transform(const Affine& a) { xf_ = a; identity_ = a.is_identity(); }
  void add(const MeshPiece& p) override {
    const std::uint32_t mat = p.material < map_.size() ? map_[p.material] : p.material;
    for (const Tri& t : p.triangles) {
      Triangle o{p.positions[t[0]], p.positions[t[1]], p.positions[t[2]], mat};
      if (!identity_) o.v0 = xf_.point(o.v0), o.v1 = xf_.point(o.v1), o.v2 = xf_.point(o.v2);
      buf_.push_back(o);
      if (buf_.size() == batch_) flush();
    }
  }
  void flush() {
    if (!buf_.empty()) fn_(std::span<const Triangle>(buf_));
    buf_.clear();
  }

 private:
  TriangleBatchFn fn_;
  std::size_t batch_;
  std::vector<Triangle> buf_;
  std::vector<std::uint32_t> map_;
  Affine xf_{};
  bool identity_ = true;
};

// What reading a mesh file found: triangles delivered (polygons are fanned into
// triangles), primitives skipped (points, lines, degenerate faces) and world bounds.
struct ImportStats {
  std::uint64_t triangles = 0;
  std::uint64_t skipped_primitives = 0;
  Bounds bounds;
};

// Counts triangles and bounds; discards geometry.
class CountingSink final : public MeshSink {
 public:
  void add(const MeshPiece& p) override {
    triangles += p.triangles.size();
    for (const Tri& t : p.triangles)
      for (auto i : t) bounds.extend(p.positions[i]);
  }
  std::uint64_t triangles = 0;
  Bounds bounds;
};

}  // namespace rayline::scene
