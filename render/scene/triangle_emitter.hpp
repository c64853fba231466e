// The output end shared by the native mesh readers: applies the import transform, keeps
// counts and world bounds in ImportStats, and hands triangles to the consumer in batches
// of `batch` (the only per-import buffer that scales with anything: batch × 40 bytes).
#pragma once
#include <algorithm>
#include <vector>

#include "render/scene/mesh_sink.hpp"

namespace rayline::scene {

class TriangleEmitter {
 public:
  TriangleEmitter(const Affine& xf, const TriangleBatchFn& fn, ImportStats& st, std::size_t batch = 1 << 16)
      : xf_(xf), identity_(xf.is_identity()), fn_(fn), st_(st), batch_(std::max<std::size_t>(batch, 1)) {
    buf_.reserve(batch_);
  }
  void emit(Float3 a, Float3 b, Float3 c, std::uint32_t material) {
    if (!identity_) a = xf_.point(a), b = xf_.point(b), c = xf_.point(c);
    st_.bounds.extend(a), st_.bounds.extend(b), st_.bounds.extend(c);
    buf_.push_back({a, b, c, material});
    ++st_.triangles;
    if (buf_.size() == batch_) flush();
  }
  // Delivers what is buffered. Call once at the end (not done by the destructor, which
  // also runs while an InputError unwinds).
  void flush() {
    if (!buf_.empty()) fn_(std::span<const Triangle>(buf_));
    buf_.clear();
  }
  void skip(std::uint64_t primitives = 1) { st_.skipped_primitives += primitives; }
  std::uint64_t triangles() const { return st_.triangles; }

 private:
  Affine xf_;
  bool identity_;
  const TriangleBatchFn& fn_;
  ImportStats& st_;
  std::size_t batch_;
  std::vector<Triangle> buf_;
};

}  // namespace rayline::scene
