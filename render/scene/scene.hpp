// The scene description (scenes/*.json, schema in scenes/README.md): materials, meshes
// (a file or a generator, with a transform), lights, cameras and camera paths.
// Loading validates everything (dangling references, out-of-range values) and throws
// InputError(file, field, message); geometry itself is streamed, never held here.
#pragma once
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "render/scene/geometry.hpp"

namespace rayline::scene {

struct Material {
  std::string name;
  Float3 albedo{0.7f, 0.7f, 0.7f};  // diffuse reflectance, each channel in [0, 1]
  Float3 emission{0, 0, 0};         // emitted radiance, >= 0
};

// A mesh: either a file (any format mesh_import reads) or a generator with parameters.
// Per-face material slots of the file map through `material_slots` to scene materials;
// faces whose slot is not listed get `material`.
struct MeshInstance {
  std::string name;
  std::string file;                  // absolute or relative to the scene file's folder; resolved on load
  std::string generator;             // e.g. "cornell" (then `file` is empty)
  std::uint64_t triangles = 0;       // generator parameter
  std::uint64_t seed = 1;            // generator parameter
  Affine transform;
  std::uint32_t material = 0;        // index into Scene::materials
  std::vector<std::uint32_t> material_slots;  // slot -> index into Scene::materials
};

// Area light: the parallelogram corner + s·edge_u + t·edge_v (s, t in [0, 1]), emitting
// `emission` on the side of cross(edge_u, edge_v).
struct AreaLight {
  std::string name;
  Float3 corner, edge_u, edge_v;
  Float3 emission{0, 0, 0};
};

// Uniform environment radiance reaching every ray that leaves the scene.
struct Environment {
  Float3 radiance{0, 0, 0};
};

struct Camera {
  std::string name;
  Float3 position{0, 0, 5};
  Float3 look_at{0, 0, 0};
  Float3 up{0, 1, 0};
  float fov_y_deg = 45.0f;
  int width = 512, height = 512;
};

enum class Interpolation { linear, catmull_rom };

struct CameraKey {
  double time = 0;  // any monotone unit; frames sample [first key, last key] uniformly
  Camera camera;    // position, look_at, up, fov used; resolution from the path's first key
};

// Key frames sampled at `frames` evenly spaced times (clients of the simulator and the
// renderer's animations both read these).
struct CameraPath {
  std::string name;
  int frames = 1;
  Interpolation interpolation = Interpolation::linear;
  std::vector<CameraKey> keys;
  Camera at_frame(int frame) const;  // frame in [0, frames)
};

struct RenderSettings {
  int spp = 4;
  int max_depth = 5;
};

struct Scene {
  std::string source;  // the file it came from ("<built-in>" for default_scene())
  std::string description;  // free text (JSON "description"); generators say what they used
  std::vector<Material> materials;
  std::vector<MeshInstance> meshes;
  std::vector<AreaLight> area_lights;
  Environment environment;
  std::vector<Camera> cameras;  // cameras[0] is the default
  std::vector<CameraPath> camera_paths;
  RenderSettings render;

  const Camera& default_camera() const { return cameras.front(); }
  std::optional<std::uint32_t> find_material(const std::string& name) const;
};

// Loads a scene JSON, or — when `path` is a mesh file — a scene framing that mesh
// (frame_mesh). Throws InputError(file, field, message).
Scene load_scene(const std::string& path);

// Parses scene JSON text; `origin` names the file in errors and relative mesh paths
// resolve against its folder.
Scene parse_scene(const std::string& json_text, const std::string& origin);

// The scene as JSON (schema of scenes/README.md). Mesh files are written relative to
// `relative_to` when given (the folder the JSON will live in).
std::string scene_to_json(const Scene& scene, const std::string& relative_to = "");

// A scene around one mesh file: a grey diffuse material, a camera looking at the
// bounds' centre from the front-above, an area light above the mesh, a dim sky.
Scene frame_mesh(const std::string& mesh_path, const Bounds& bounds);
// Camera and lights only, for already known bounds (used by frame_mesh and generators).
void frame_bounds(Scene& scene, const Bounds& bounds);

// The built-in scene: a generated Cornell-box-like room (no files needed), so that
// `rayline render` and `rayline simulate` run with no flags.
Scene default_scene();

// Throws InputError when the scene is inconsistent (also called by load_scene).
void validate(const Scene& scene);

}  // namespace rayline::scene
