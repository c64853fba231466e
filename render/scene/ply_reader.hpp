// Native streaming reader for binary PLY (either byte order): the fast path for big
// meshes (generated scenes, scans), which assimp would load whole into memory. The file
// is memory-mapped; faces are delivered in batches of world-space triangles.
#pragma once
#include <cstdint>
#include <string>

#include "render/scene/mesh_sink.hpp"

namespace rayline::scene {

struct PlyHeaderInfo {
  bool binary = false;
  bool big_endian = false;
  std::uint64_t vertices = 0;
  std::uint64_t faces = 0;
  bool streamable = false;  // the native reader can read it (else: use assimp)
};

// Parses the header only. Throws InputError(path, ...) when it is not a PLY file.
PlyHeaderInfo read_ply_header(const std::string& path);

// Streams every face as triangles (polygons fanned, faces with < 3 vertices skipped and
// counted). Face property `material_index` (if present) becomes Triangle::material.
// Throws InputError for truncated files or out-of-range indices.
ImportStats stream_ply(const std::string& path, const Affine& transform, const TriangleBatchFn& fn,
                       std::size_t batch = 1 << 16);

}  // namespace rayline::scene
