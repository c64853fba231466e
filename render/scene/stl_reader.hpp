// Native streaming readers for STL, binary and ASCII; both are triangle soups, so any
// size streams in bounded memory. Binary (80-byte header, uint32 count, 50 bytes per
// triangle) is read in fixed-size chunks; ASCII facet by facet, line by line
// (mesh_import.cpp picks the route with is_binary_stl).
#pragma once
#include <string>

#include "render/scene/mesh_sink.hpp"

namespace rayline::scene {

// True when `path` is a binary STL: its size is exactly 84 + 50·count, or it does not
// start with "solid", or its first 512 bytes hold a NUL byte, which no ASCII STL has
// (then a size mismatch is an error reported by stream_stl).
bool is_binary_stl(const std::string& path);

// Streams every facet as a world-space triangle (the facet's attribute word is ignored,
// material 0). Throws InputError(path, field, ...) for a missing or short header
// ("header"), a count that disagrees with the file size ("triangle_count"), a
// truncated read or non-finite vertex ("triangle[i]").
ImportStats stream_stl(const std::string& path, const Affine& transform, const TriangleBatchFn& fn,
                       std::size_t batch = 1 << 16);

// Streams an ASCII STL ("solid", then "facet normal .. / outer loop / vertex x y z ... /
// endloop / endfacet", "endsolid"; several solids may follow each other; keywords in
// any case). Loops of more than 3 vertices are fanned, of fewer skipped and counted.
// Throws InputError(path, "line N", ...) for unexpected keywords, malformed vertices and
// a file that ends inside a solid (truncated), InputError(path, "header", ...) when it
// does not start with "solid".
ImportStats stream_ascii_stl(const std::string& path, const Affine& transform, const TriangleBatchFn& fn,
                             std::size_t batch = 1 << 16);

}  // namespace rayline::scene
