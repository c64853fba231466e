// Scene descriptions (`rayline render --scene FILE.json`, `partition --scene`):
// render/scene/scene_json.cpp's load_scene, then the cameras a render would place (the
// default camera and every camera path's first, middle and last frame).
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "render/scene/scene.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rayline::fuzz::write_input("scene.json", data, size);
  rayline::fuzz::expect_clean("scene", [&] {
    const rayline::scene::Scene s = rayline::scene::load_scene(path);
    (void)s.default_camera();
    for (const rayline::scene::CameraPath& p : s.camera_paths)
      for (int f : {0, p.frames / 2, p.frames - 1}) (void)p.at_frame(f);
  });
  return 0;
}
