// Triangles out of a scene assimp has imported (mesh_import.hpp's fallback path). Assimp
// hands over whatever its importer built, so nothing in the aiScene is trusted: the node
// graph is walked iteratively (a deep hierarchy cannot overflow the stack), null nodes
// and meshes and a node reached twice are errors, and every mesh index of a node and every
// vertex index of a face is checked against what it indexes.
#pragma once
#include <string>

#include "render/scene/mesh_sink.hpp"

struct aiScene;

namespace rayline::scene {

// Checks what assimp's own post-processing (Triangulate, SortByPType) relies on before it
// runs: every mesh non-null with its vertex and face arrays, every face with at least one
// index and every index below the mesh's vertex count. Throws InputError(path,
// "meshes[i] 'name'.faces[f]", ...) naming the first offender.
void check_ai_meshes(const aiScene& scene, const std::string& path);

// Delivers every triangle of `scene` (node transforms applied, then `transform`) to `fn`;
// points, lines and polygons that are not triangles are skipped and counted. Throws
// InputError(path, field, ...) for a malformed scene, field naming the node, mesh and face
// (e.g. "meshes[2] 'Cube'.faces[7]").
ImportStats stream_ai_scene(const aiScene& scene, const std::string& path, const Affine& transform,
                            const TriangleBatchFn& fn);

}  // namespace rayline::scene
