// Mesh files → triangle batches, in bounded memory whatever the file size. Native
// streaming readers handle OBJ (obj_reader.hpp), OFF (off_reader.hpp), PLY ASCII and
// binary (ply_reader.hpp), STL ASCII and binary (stl_reader.hpp) and glTF 2.0 / GLB
// (gltf_reader.hpp); indexed text formats keep their vertices in a disk-backed spill file
// (spill_file.hpp), never in RAM. Assimp, which loads whole files into memory, remains
// only for: ImportPath::assimp; formats without a native reader (3DS, FBX, DAE, ...);
// PLY layouts the native reader does not take (ply_reader.hpp); glTF 1.0, sparse
// accessors and Draco/meshopt-compressed glTF (gltf_reader.hpp). Everywhere polygons are
// triangulated, points and lines skipped and counted, and node hierarchies flattened into
// the vertices. Assimp runs in a child process (isolated_import.hpp): a file it crashes
// or loops on is an InputError, like any other malformed file.
#pragma once
#include <string>

#include "render/scene/mesh_sink.hpp"

namespace rayline::scene {

// automatic: the native reader where there is one (else assimp); assimp: always assimp
// (reference results for tests).
enum class ImportPath { automatic, assimp };

// Delivers all triangles of `path`, transformed by `transform`, to `fn`. Triangle::material
// is the mesh-local material slot (PLY material_index, OBJ usemtl order, glTF primitive
// material, assimp's material index).
// Throws InputError(path, field, ...) for missing, unreadable or malformed files, and for
// files without any triangle.
ImportStats stream_mesh_file(const std::string& path, const Affine& transform, const TriangleBatchFn& fn,
                             ImportPath route = ImportPath::automatic);

// Triangle count, skipped primitives and bounds of a mesh file (one streaming pass).
ImportStats mesh_file_stats(const std::string& path, const Affine& transform = {});

// Whether `path` has an extension this build can import (native readers or assimp).
bool is_mesh_file(const std::string& path);

}  // namespace rayline::scene
