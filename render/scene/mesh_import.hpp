// Mesh files → triangle batches. Binary PLY and binary STL stream through native readers
// (bounded memory, any size); everything else (OBJ, ASCII PLY, STL, OFF, glTF 2.0 / GLB, and
// whatever else assimp reads) goes through assimp, with polygons triangulated, points
// and lines skipped and counted, and the node hierarchy flattened into the vertices.
#pragma once
#include <string>

#include "render/scene/mesh_sink.hpp"

namespace rayline::scene {

enum class ImportPath { automatic, assimp };

// Delivers all triangles of `path`, transformed by `transform`, to `fn`. Triangle::material
// is the mesh-local material slot (PLY material_index, assimp's material index).
// Throws InputError(path, ...) for missing, unreadable or malformed files.
ImportStats stream_mesh_file(const std::string& path, const Affine& transform, const TriangleBatchFn& fn,
                             ImportPath route = ImportPath::automatic);

// Triangle count, skipped primitives and bounds of a mesh file (one streaming pass).
ImportStats mesh_file_stats(const std::string& path, const Affine& transform = {});

// Extensions this build can import (lower case, with dot), for messages and --help.
bool is_mesh_file(const std::string& path);

}  // namespace rayline::scene
