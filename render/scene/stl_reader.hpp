// Native streaming reader for binary STL: a triangle soup (80-byte header, uint32
// count, 50 bytes per triangle), read in fixed-size chunks, so any size streams in
// bounded memory. ASCII STL stays on assimp (mesh_import.cpp picks the route).
#pragma once
#include <string>

#include "render/scene/mesh_sink.hpp"

namespace rayline::scene {

// True when `path` is a binary STL: its size is exactly 84 + 50·count, or it does not
// start with "solid" (then a size mismatch is an error reported by stream_stl).
bool is_binary_stl(const std::string& path);

// Streams every facet as a world-space triangle (the facet's attribute word is ignored,
// material 0). Throws InputError(path, field, ...) for a missing or short header
// ("header"), a count that disagrees with the file size ("triangle_count"), a
// truncated read or non-finite vertex ("triangle[i]").
ImportStats stream_stl(const std::string& path, const Affine& transform, const TriangleBatchFn& fn,
                       std::size_t batch = 1 << 16);

}  // namespace rayline::scene
