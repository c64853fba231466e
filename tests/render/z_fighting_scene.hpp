// Test support: a scene built to z-fight. Two coplanar floors in the plane y = 0 over
// [0, 1]^2, tessellated differently, with different materials: every ray that meets the
// floor meets two triangles at the same t up to rounding, so the image depends on every
// last bit of the triangle test (which engine, which Embree kernel) unless the renderer
// makes it not. Written to a TempScene.
#pragma once
#include <fstream>
#include <nlohmann/json.hpp>

#include "temp_scene.hpp"

namespace rayline::testing {

// A scene made to crack: two coplanar floors in the plane y = 0 over [0, 1]^2, tessellated
// differently (70 x 70 cells cut along one diagonal, 90 x 90 along the other) with different
// materials — z-fighting. Every ray that meets the floor meets two triangles at the same t
// up to rounding, and Embree (t = T * rcp(|den|), fused multiply-adds) and the kernel (T /
// |den|; lavapipe does not fuse) round differently, so without the doubtful-ray hand-over
// the two images differ in many pixels; the grid's shared edges add edge cracks.
struct ZFightingScene : TempScene {
  ZFightingScene() : TempScene("rayline-zfight-") {}
};

inline void write_z_fighting_scene(ZFightingScene& out) {
  const std::filesystem::path& dir = out.dir;
  auto grid = [&](const char* name, int n, bool other_diagonal) {
    write_grid_obj(dir / name, n, n, [n](int i, int j) {
      return std::array<double, 3>{float(i) / float(n), 0.0, float(j) / float(n)};
    }, other_diagonal);
  };
  grid("a.obj", 70, false);
  grid("b.obj", 90, true);
  std::ofstream(dir / "wall.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";  // gives the cells height
  const nlohmann::json scene = {
      {"version", 1},
      {"materials", {{"red", {{"albedo", {0.8, 0.1, 0.1}}}}, {"green", {{"albedo", {0.1, 0.7, 0.2}}}},
                     {"white", {{"albedo", {0.7, 0.7, 0.7}}}}}},
      {"meshes", {{{"name", "a"}, {"file", "a.obj"}, {"material", "red"}},
                  {{"name", "b"}, {"file", "b.obj"}, {"material", "green"}},
                  {{"name", "wall"}, {"file", "wall.obj"}, {"material", "white"}}}},
      {"lights", {{{"type", "area"}, {"corner", {0.3, 1.5, 0.3}}, {"edge_u", {0.4, 0, 0}}, {"edge_v", {0, 0, 0.4}},
                   {"emission", {8, 8, 8}}},
                  {{"type", "environment"}, {"radiance", {0.3, 0.4, 0.5}}}}},
      {"cameras", {{"main", {{"position", {0.5, 1.3, 1.6}}, {"look_at", {0.5, 0, 0.45}}, {"fov_deg", 45}}}}}};
  std::ofstream(out.path) << scene.dump(2);
}

}  // namespace rayline::testing
