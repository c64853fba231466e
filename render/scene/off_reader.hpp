// Native streaming reader for OFF (Object File Format, ASCII), bounded memory.
//
// Header: an optional keyword [ST][C][N][4]OFF (also "OFF" glued to the first count, as
// in ModelNet), then "vertices faces [edges]". Vertices (first 3 numbers of a line; with
// '4', x y z w divided by w; colours, normals, texture coordinates after them ignored)
// go to a disk-backed SpillArray; each face line "n i0 .. in-1 [colour]" is
// fan-triangulated and emitted at once. Faces with fewer than 3 vertices are skipped
// and counted. '#' starts a comment; blank lines are ignored. Binary OFF and nOFF
// (other dimensions) are not supported (InputError).
#pragma once
#include <string>

#include "render/scene/mesh_sink.hpp"

namespace rayline::scene {

// Throws InputError(path, field, ...): "header" (bad keyword or counts), "vertex_count" /
// "face_count" (file ends early), "line N" (malformed vertex or face, index out of range).
ImportStats stream_off(const std::string& path, const Affine& transform, const TriangleBatchFn& fn,
                       std::size_t batch = 1 << 16);

}  // namespace rayline::scene
