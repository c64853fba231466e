// Scene profiles (`rayline simulate --workload FILE.profile.json`):
// workload/scene_profile_loader, and the derived sizes the workload reads first.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "workload/scene_profile.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rayline::fuzz::write_input("scene.profile.json", data, size);
  rayline::fuzz::expect_clean("scene_profile", [&] {
    const rayline::SceneProfile p = rayline::load_scene_profile(path);
    (void)p.scene_bytes();
    for (int t = 0; t < p.tiles(); ++t) (void)p.tile_pixels(t);
  });
  return 0;
}
