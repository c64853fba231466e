// Native streaming reader for glTF 2.0 (.gltf with external or embedded buffers, .glb).
//
// The JSON part (small: scene graph, accessors) is parsed with nlohmann_json. Buffer
// data is never copied: the .glb BIN chunk and external .bin files are memory-mapped
// and read accessor by accessor, primitive by primitive, node instance by node
// instance, with mapped pages dropped from the resident set every million triangles.
// The exception is a `data:` URI (base64 inside the JSON), which is decoded into memory
// on first use — such files are small by nature (the JSON text holds the data anyway).
//
// Geometry: the default scene (`scene`, else scenes[0], else every root node) is walked
// and each node's mesh is emitted in world space (node `matrix` or T·R·S composed down
// the hierarchy, then the import transform): instanced meshes are emitted once per node.
// TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN (indexed or not) become triangles;
// POINTS (one per point), LINES / LINE_LOOP / LINE_STRIP (one per segment) and
// primitives without POSITION are skipped and counted. POSITION may be float or, with
// KHR_mesh_quantization, (normalized) integers. Triangle::material is the primitive's
// `material` index (0 without one). Morph targets and skins are ignored (base pose).
//
// Not native (returns nullopt before emitting anything; mesh_import.cpp then uses
// assimp): glTF 1.0, sparse accessors or accessors without a bufferView, and files that
// require Draco or meshopt compression.
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "render/scene/mesh_sink.hpp"

namespace rayline::scene {

// Throws InputError(path, field, ...) with the JSON path of the offending value
// ("accessors[2].count", "meshes[0].primitives[1].indices", "buffers[0].uri", "glb
// header", "json", ...) for malformed files, out-of-range accessors or indices and
// missing or short buffer files.
std::optional<ImportStats> stream_gltf(const std::string& path, const Affine& transform, const TriangleBatchFn& fn,
                                       std::size_t batch = 1 << 16);

// The files a .gltf/.glb reads besides itself or names as textures: buffers[].uri and
// images[].uri that are not data: URIs, resolved beside the document (so that outputs can
// be kept from replacing them). Best effort: a damaged document yields what was readable.
std::vector<std::string> gltf_external_files(const std::string& path);

}  // namespace rayline::scene
