// Test support for scenes a test writes: a folder under the system temp dir for its meshes
// and scene.json, removed again when the TempScene goes out of scope, and grid meshes.
#pragma once
#include <unistd.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

namespace rayline::testing {

struct TempScene {
  std::filesystem::path dir;
  std::string path;  // dir / scene.json
  explicit TempScene(const std::string& prefix)
      : dir(std::filesystem::temp_directory_path() / (prefix + std::to_string(::getpid()))),
        path((dir / "scene.json").string()) {
    std::filesystem::create_directories(dir);
  }
  TempScene(const TempScene&) = delete;
  TempScene& operator=(const TempScene&) = delete;
  ~TempScene() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
};

// An OBJ file of a grid of (nu + 1) x (nv + 1) vertices, `point(u, v)` for u in [0, nu] and v
// in [0, nv], two triangles per cell, cut along the diagonal from (u, v) to (u + 1, v + 1)
// or, with `other_diagonal`, the other one.
template <class Point>
void write_grid_obj(const std::filesystem::path& file, int nu, int nv, const Point& point, bool other_diagonal = false) {
  std::ofstream f(file);
  for (int v = 0; v <= nv; ++v)
    for (int u = 0; u <= nu; ++u) {
      const std::array<double, 3> p = point(u, v);
      f << "v " << p[0] << " " << p[1] << " " << p[2] << "\n";
    }
  for (int v = 0; v < nv; ++v)
    for (int u = 0; u < nu; ++u) {
      const int a = v * (nu + 1) + u + 1, b = a + 1, c = a + nu + 1, d = c + 1;  // OBJ: 1-based
      if (other_diagonal) f << "f " << a << " " << b << " " << c << "\nf " << b << " " << d << " " << c << "\n";
      else f << "f " << a << " " << b << " " << d << "\nf " << a << " " << d << " " << c << "\n";
    }
}

}  // namespace rayline::testing
