#include "render/scene/scene.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>

#include "common/error.hpp"

namespace rayline::scene {
namespace {

Float3 catmull_rom(Float3 p0, Float3 p1, Float3 p2, Float3 p3, float t) {
  const float t2 = t * t, t3 = t2 * t;
  return 0.5f * ((2.0f * p1) + (p2 - p0) * t + (2.0f * p0 - 5.0f * p1 + 4.0f * p2 - p3) * t2 +
                 (3.0f * p1 - p0 - 3.0f * p2 + p3) * t3);
}

bool finite(Float3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

std::string bounds_text(const Bounds& b) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "[%g %g %g] .. [%g %g %g]", b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z);
  return buf;
}

}  // namespace

std::optional<std::uint32_t> Scene::find_material(const std::string& name) const {
  for (std::size_t i = 0; i < materials.size(); ++i)
    if (materials[i].name == name) return static_cast<std::uint32_t>(i);
  return std::nullopt;
}

Camera CameraPath::at_frame(int frame) const {
  const Camera& first = keys.front().camera;
  if (keys.size() == 1) return first;
  const double t0 = keys.front().time, t1 = keys.back().time;
  const double t = frames <= 1 ? t0 : t0 + (t1 - t0) * double(std::clamp(frame, 0, frames - 1)) / (frames - 1);
  std::size_t i = 0;
  while (i + 2 < keys.size() && keys[i + 1].time <= t) ++i;
  const CameraKey& a = keys[i];
  const CameraKey& b = keys[i + 1];
  const float u = b.time > a.time ? float(std::clamp((t - a.time) / (b.time - a.time), 0.0, 1.0)) : 0.0f;
  Camera c = first;
  c.name = name + "#" + std::to_string(frame);
  if (interpolation == Interpolation::linear) {
    c.position = lerp(a.camera.position, b.camera.position, u);
    c.look_at = lerp(a.camera.look_at, b.camera.look_at, u);
  } else {
    const CameraKey& p = keys[i == 0 ? 0 : i - 1];
    const CameraKey& q = keys[std::min(i + 2, keys.size() - 1)];
    c.position = catmull_rom(p.camera.position, a.camera.position, b.camera.position, q.camera.position, u);
    c.look_at = catmull_rom(p.camera.look_at, a.camera.look_at, b.camera.look_at, q.camera.look_at, u);
  }
  c.up = normalize(lerp(a.camera.up, b.camera.up, u));
  c.fov_y_deg = a.camera.fov_y_deg + (b.camera.fov_y_deg - a.camera.fov_y_deg) * u;
  return c;
}

namespace {

// Colour components finite and within [0, hi].
void check_color(const std::string& f, const std::string& field, Float3 c, float hi) {
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(c[i]) || c[i] < 0 || c[i] > hi)
      throw InputError(f, field, "component " + std::to_string(c[i]) + " out of range [0, " +
                                     (std::isinf(hi) ? std::string("inf") : std::to_string(hi)) + "]");
}

void check_materials(const Scene& s) {
  const std::string& f = s.source;
  std::set<std::string> names;
  for (const auto& m : s.materials) {
    const std::string field = "materials." + m.name;
    if (!names.insert(m.name).second) throw InputError(f, field, "duplicate material name");
    check_color(f, field + ".albedo", m.albedo, 1.0f);
    check_color(f, field + ".emission", m.emission, INFINITY);
  }
}

void check_meshes(const Scene& s) {
  const std::string& f = s.source;
  if (s.meshes.empty()) throw InputError(f, "meshes", "a scene needs at least one mesh");
  for (std::size_t i = 0; i < s.meshes.size(); ++i) {
    const auto& m = s.meshes[i];
    const std::string field = "meshes[" + std::to_string(i) + "]";
    if (m.file.empty() == m.generator.empty())
      throw InputError(f, field, "needs exactly one of \"file\" and \"generator\"");
    if (m.material >= s.materials.size()) throw InputError(f, field + ".material", "unknown material");
    for (auto slot : m.material_slots)
      if (slot >= s.materials.size()) throw InputError(f, field + ".material_slots", "unknown material");
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        if (!std::isfinite(m.transform.m[r][c])) throw InputError(f, field + ".transform", "not finite");
  }
}

void check_lights(const Scene& s) {
  const std::string& f = s.source;
  for (std::size_t i = 0; i < s.area_lights.size(); ++i) {
    const auto& l = s.area_lights[i];
    const std::string field = "lights[" + std::to_string(i) + "]";
    check_color(f, field + ".emission", l.emission, INFINITY);
    if (!finite(l.corner)) throw InputError(f, field + ".corner", "not finite");
    if (!(length(cross(l.edge_u, l.edge_v)) > 0)) throw InputError(f, field, "edges span no area");
  }
  check_color(f, "environment.radiance", s.environment.radiance, INFINITY);
}

void check_camera(const std::string& f, const std::string& field, const Camera& c) {
  if (!finite(c.position) || !finite(c.look_at) || !finite(c.up)) throw InputError(f, field, "not finite");
  if (!(length(c.look_at - c.position) > 0)) throw InputError(f, field + ".look_at", "equals position");
  if (!(length(cross(normalize(c.look_at - c.position), normalize(c.up))) > 1e-6f))
    throw InputError(f, field + ".up", "parallel to the viewing direction (or zero)");
  if (!(c.fov_y_deg > 0 && c.fov_y_deg < 180)) throw InputError(f, field + ".fov_deg", "must be in (0, 180)");
  if (c.width < 1 || c.height < 1 || c.width > 65536 || c.height > 65536)
    throw InputError(f, field + ".resolution", "must be in [1, 65536]");
}

void check_cameras(const Scene& s) {
  const std::string& f = s.source;
  if (s.cameras.empty()) throw InputError(f, "cameras", "a scene needs at least one camera");
  std::set<std::string> names;
  for (const auto& c : s.cameras) {
    if (!names.insert(c.name).second) throw InputError(f, "cameras." + c.name, "duplicate camera name");
    check_camera(f, "cameras." + c.name, c);
  }
}

void check_camera_paths(const Scene& s) {
  const std::string& f = s.source;
  std::set<std::string> names;
  for (const auto& p : s.camera_paths) {
    const std::string field = "camera_paths." + p.name;
    if (!names.insert(p.name).second) throw InputError(f, field, "duplicate camera path name");
    if (p.frames < 1) throw InputError(f, field + ".frames", "must be >= 1");
    if (p.keys.empty()) throw InputError(f, field + ".keys", "needs at least one key");
    for (std::size_t k = 0; k < p.keys.size(); ++k) {
      const std::string kf = field + ".keys[" + std::to_string(k) + "]";
      if (!std::isfinite(p.keys[k].time)) throw InputError(f, kf + ".t", "not finite");
      if (k > 0 && !(p.keys[k].time > p.keys[k - 1].time)) throw InputError(f, kf + ".t", "times must increase");
      check_camera(f, kf, p.keys[k].camera);
    }
  }
}

}  // namespace

void validate(const Scene& s) {
  check_materials(s);
  check_meshes(s);
  check_lights(s);
  check_cameras(s);
  check_camera_paths(s);
  if (s.render.spp < 1) throw InputError(s.source, "render.spp", "must be >= 1");
  if (s.render.max_depth < 1) throw InputError(s.source, "render.max_depth", "must be >= 1");
}

void frame_bounds(Scene& s, const Bounds& b) {
  const Float3 c = b.center();
  const Float3 e = b.extent();
  const float radius = std::max(0.5f * length(e), 1e-3f);
  Camera cam;
  cam.name = "main";
  cam.fov_y_deg = 40.0f;
  const float dist = radius / std::sin(0.5f * cam.fov_y_deg * 3.14159265f / 180.0f) * 1.05f;
  const Float3 dir = normalize(Float3{0.35f, 0.45f, 1.0f});
  cam.position = c + dir * dist;
  cam.look_at = c;
  cam.up = {0, 1, 0};
  s.cameras = {cam};
  // A square light above the mesh, a diameter wide, facing down: it emits along
  // edge_u x edge_v (path_kernels.cpp, next-event estimation), here (0, -w^2, 0).
  const float w = 2.0f * radius;
  AreaLight l;
  l.name = "key";
  l.corner = {c.x - 0.5f * w, b.hi.y + radius, c.z - 0.5f * w};
  l.edge_u = {w, 0, 0};
  l.edge_v = {0, 0, w};
  l.emission = {4, 4, 4};
  s.area_lights = {l};
  s.environment.radiance = {0.3f, 0.3f, 0.35f};
  // An orbit for clients and animations.
  CameraPath orbit;
  orbit.name = "orbit";
  orbit.frames = 60;
  orbit.interpolation = Interpolation::catmull_rom;
  for (int k = 0; k <= 8; ++k) {
    const float a = 2.0f * 3.14159265f * float(k) / 8.0f;
    CameraKey key;
    key.time = k;
    key.camera = cam;
    const float hz = std::sqrt(dir.x * dir.x + dir.z * dir.z);
    key.camera.position = c + Float3{hz * std::sin(a), dir.y, hz * std::cos(a)} * dist;
    orbit.keys.push_back(key);
  }
  s.camera_paths = {orbit};
}

Scene frame_mesh(const std::string& mesh_path, const Bounds& bounds) {
  Scene s;
  s.source = mesh_path;
  s.materials = {{"default", {0.7f, 0.7f, 0.7f}, {0, 0, 0}}};
  MeshInstance m;
  m.name = std::filesystem::path(mesh_path).stem().string();
  m.file = std::filesystem::absolute(mesh_path).lexically_normal().string();
  s.meshes = {m};
  if (bounds.empty()) throw InputError(mesh_path, "", "mesh has no triangles");
  frame_bounds(s, bounds);
  // Float arithmetic can fail to place a camera: an extent that overflows (coordinates
  // near ±3.4e38), or a mesh so small against its distance from the origin that the
  // camera rounds onto the point it looks at.
  const Camera& cam = s.cameras.front();
  if (!finite(cam.position) || !(length(cam.look_at - cam.position) > 0) || !finite(s.area_lights.front().corner))
    throw InputError(mesh_path, "", "cannot frame a camera on the mesh bounds " + bounds_text(bounds) +
                                        " in single precision (too large, or too small for its distance from "
                                        "the origin): scale or move the mesh");
  return s;
}

}  // namespace rayline::scene
