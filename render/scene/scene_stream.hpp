// The renderer's entry to geometry: every triangle of a scene, in world space, with
// scene material indices, streamed in batches (files through mesh_import, generator
// meshes straight from the generator: nothing is written or held whole).
#pragma once
#include <cstddef>

#include "render/scene/mesh_sink.hpp"
#include "render/scene/scene.hpp"

namespace rayline::scene {

// One mesh of the scene. Triangle::material is an index into scene.materials.
ImportStats stream_scene_mesh(const Scene& scene, std::size_t mesh_index, const TriangleBatchFn& fn);

// All meshes in order; the returned stats sum them.
ImportStats stream_scene(const Scene& scene, const TriangleBatchFn& fn);

// Bounds and triangle count of the whole scene (one streaming pass).
ImportStats scene_stats(const Scene& scene);

}  // namespace rayline::scene
