// Test support: a scene of fine geometry — a terrain (2 × 160² triangles, half flat, half
// rippled) with a sphere of 2 × 96 × 64 triangles resting on it, under an area light — so
// that a partition into many blocks cuts thousands of small triangles, rays cross many split
// planes between close hits, and shadow rays graze the surfaces (in a TempScene).
#pragma once
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "temp_scene.hpp"

namespace rayline::testing {

struct FineGeometryScene : TempScene {
  FineGeometryScene() : TempScene("rayline-fine-") {}
};

inline void write_fine_geometry_scene(FineGeometryScene& out) {
  const std::filesystem::path& dir = out.dir;
  // The terrain over [0, 1]^2: flat (y = 0) for x < 0.5, many triangles in one plane, then
  // y = 0.03 sin(23 (x - 0.5)) cos(17 z).
  write_grid_obj(dir / "terrain.obj", 160, 160, [](int i, int j) {
    const double x = i / 160.0, z = j / 160.0;
    return std::array<double, 3>{x, x < 0.5 ? 0.0 : 0.03 * std::sin(23 * (x - 0.5)) * std::cos(17 * z), z};
  });
  // The sphere: centre (0.55, 0.2, 0.45), radius 0.18, 96 x 64 quads.
  write_grid_obj(dir / "sphere.obj", 96, 64, [](int u, int v) {
    const double th = M_PI * v / 64, ph = 2 * M_PI * u / 96;
    return std::array<double, 3>{0.55 + 0.18 * std::sin(th) * std::cos(ph), 0.2 + 0.18 * std::cos(th),
                                 0.45 + 0.18 * std::sin(th) * std::sin(ph)};
  });
  const nlohmann::json scene = {
      {"version", 1},
      {"materials", {{"sand", {{"albedo", {0.75, 0.65, 0.45}}}}, {"blue", {{"albedo", {0.2, 0.35, 0.8}}}}}},
      {"meshes", {{{"name", "terrain"}, {"file", "terrain.obj"}, {"material", "sand"}},
                  {{"name", "sphere"}, {"file", "sphere.obj"}, {"material", "blue"}}}},
      {"lights", {{{"type", "area"}, {"corner", {0.2, 1.2, 0.2}}, {"edge_u", {0.3, 0, 0}}, {"edge_v", {0, 0, 0.3}},
                   {"emission", {10, 10, 10}}},
                  {{"type", "environment"}, {"radiance", {0.25, 0.3, 0.4}}}}},
      {"cameras", {{"main", {{"position", {0.5, 0.55, 1.35}}, {"look_at", {0.5, 0.05, 0.45}}, {"fov_deg", 50}}}}}};
  std::ofstream(out.path) << scene.dump(2);
}

}  // namespace rayline::testing
