// Native streaming reader for PLY, ASCII and binary (either byte order), bounded memory.
//
// Binary: the file is memory-mapped; the vertex element (fixed size) is indexed in place
// and faces are streamed in order, with the pages read so far dropped from the resident
// set every 64 MiB. Elements of variable size before the face element are walked over.
// ASCII: one element per line; vertices (x, y, z of each vertex line) go to a
// disk-backed SpillArray (spill_file.hpp), then face lines are fan-triangulated as they
// are read; when the face element comes before the vertex element the file is read
// twice (vertices, then faces). Either way polygons are fanned, faces with fewer than 3
// vertices skipped and counted, other elements and properties ignored, and the face
// property `material_index` (if present) becomes Triangle::material.
//
// Refused when the header is read, before either path, with InputError(path,
// "header.property" or "header.element", ...): a list length type or a vertex index type
// that is not an integer type, a property name repeated within an element, two vertex
// index lists in one element, an element name declared twice; and ("header") a line
// that is none of format, comment, obj_info, element, property and end_header.
// Not native (mesh_import.cpp hands these to assimp): a vertex element without scalar
// x, y, z; no `face` element with an integer `vertex_indices`/`vertex_index` list (e.g.
// triangle strips only); in binary files, a vertex element with list properties.
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

// Parses the header only. Throws InputError(path, "header...", ...) when it is not a PLY file.
PlyHeaderInfo read_ply_header(const std::string& path);

// Streams every face as triangles. Throws InputError(path, field, ...) for truncated files
// (field "vertex" / "face"), out-of-range indices ("face.vertex_indices" in binary files,
// "line N" in ASCII ones) and malformed ASCII lines ("line N").
ImportStats stream_ply(const std::string& path, const Affine& transform, const TriangleBatchFn& fn,
                       std::size_t batch = 1 << 16);

}  // namespace rayline::scene
