// Test support: a folder under the system temp dir for a scene written by a test (its
// meshes and scene.json), removed again when the TempScene goes out of scope.
#pragma once
#include <unistd.h>

#include <filesystem>
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

}  // namespace rayline::testing
