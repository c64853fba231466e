// Native streaming reader for Wavefront OBJ (bounded memory, any size).
//
// One pass over the text: `v` lines go to a disk-backed SpillArray (spill_file.hpp),
// `f` lines are fan-triangulated and emitted at once, looking their vertices up in the
// spill. Faces may use `v`, `v/vt`, `v//vn`, `v/vt/vn` and negative (relative) indices;
// a face that names a vertex defined later in the file (legal, rare) is left for a
// second pass that re-reads the file and emits only those faces once every vertex is
// known. `l` (one primitive per segment), `p` (one per point), faces with fewer than 3
// vertices and free-form `curv`/`curv2`/`surf` are skipped and counted; `vt`, `vn`,
// groups, smoothing, `mtllib` and unknown statements are ignored. Lines ending in '\'
// continue on the next line; '#' starts a comment.
//
// Material slots: each distinct `usemtl` name gets the next slot in order of first
// appearance; faces before any `usemtl` form slot 0 of their own (names then start at 1).
#pragma once
#include <string>

#include "render/scene/mesh_sink.hpp"

namespace rayline::scene {

// Throws InputError(path, "line N", ...) for malformed statements and indices that are
// zero, reach before the first vertex or beyond the last one.
ImportStats stream_obj(const std::string& path, const Affine& transform, const TriangleBatchFn& fn,
                       std::size_t batch = 1 << 16);

}  // namespace rayline::scene
