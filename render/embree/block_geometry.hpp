// One scene block made traceable (Sec. 6: "each block has its own BVH"): the triangles of a
// block file as an Embree 3 scene, plus what shading needs (vertices, materials).
// Built by the disk→RAM T-job (read + BVH build), dropped when the plan evicts the block.
// Embree types stay out of this header.
#pragma once
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "render/scene/geometry.hpp"

namespace rayline::trace {

class ArrayPool;

// An Embree device shared by all blocks. `build_threads` bounds the threads one BVH build
// uses (the loader is one channel: one thread by default, so builds never steal the
// compute devices' cores). Tracks the bytes Embree holds.
class EmbreeDevice {
 public:
  explicit EmbreeDevice(int build_threads = 1);
  ~EmbreeDevice();
  EmbreeDevice(const EmbreeDevice&) = delete;
  EmbreeDevice& operator=(const EmbreeDevice&) = delete;
  void* handle() const { return device_; }
  std::int64_t embree_bytes() const;        // currently allocated by Embree
  std::int64_t peak_embree_bytes() const;
  struct Counter;  // Embree's memory monitor callback adds to it

 private:
  void* device_ = nullptr;
  std::unique_ptr<Counter> counter_;
};

// BVH build quality. Every quality gives the same hits (the same triangle intersector; the
// images are identical, tested), only build and trace speed and memory differ.
enum class BvhQuality : std::uint8_t { Low, Medium, High };

class BlockGeometry {
 public:
  // `records` is the block file payload: triangle_count records of 9 float32 + uint32
  // material (little-endian, block_file.hpp). With a `pool` (which must outlive the block)
  // the arrays are taken from it and given back when the block is dropped.
  BlockGeometry(const EmbreeDevice& device, std::uint32_t block, std::span<const unsigned char> records,
                std::uint64_t triangle_count, BvhQuality quality = BvhQuality::Medium, ArrayPool* pool = nullptr);
  ~BlockGeometry();
  BlockGeometry(const BlockGeometry&) = delete;
  BlockGeometry& operator=(const BlockGeometry&) = delete;

  std::uint32_t block() const { return block_; }
  std::uint64_t triangles() const { return materials_.size(); }
  void* scene() const { return scene_; }  // RTCScene (nullptr for an empty block)
  scene::Float3 vertex(std::uint32_t prim, int k) const {
    const float* v = &vertices_[(std::size_t(prim) * 3 + std::size_t(k)) * 3];
    return {v[0], v[1], v[2]};
  }
  std::uint32_t material(std::uint32_t prim) const { return materials_[prim]; }
  // The block file records (9 float32 + uint32 material per triangle, little-endian host
  // assumed as in block_file.hpp) rebuilt from RAM: what the RAM->GPU T-job uploads.
  std::vector<unsigned char> records() const;
  // Bytes held outside Embree (vertices, indices, materials).
  std::uint64_t array_bytes() const;

 private:
  std::uint32_t block_;
  std::vector<float> vertices_;         // 9 floats per triangle (+ padding Embree reads)
  std::vector<std::uint32_t> indices_;  // 3 per triangle: 3i, 3i+1, 3i+2
  std::vector<std::uint32_t> materials_;
  void* scene_ = nullptr;
  ArrayPool* pool_ = nullptr;
};

}  // namespace rayline::trace
