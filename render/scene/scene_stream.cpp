#include "render/scene/scene_stream.hpp"

#include <vector>

#include "render/scene/generators.hpp"
#include "render/scene/mesh_import.hpp"

namespace rayline::scene {

ImportStats stream_scene_mesh(const Scene& scene, std::size_t i, const TriangleBatchFn& fn) {
  const MeshInstance& m = scene.meshes.at(i);
  // Slot → scene material; slots beyond the list get the mesh's material.
  auto resolve = [&m](std::uint32_t slot) { return slot < m.material_slots.size() ? m.material_slots[slot] : m.material; };
  if (!m.file.empty()) {
    std::vector<Triangle> buf;
    return stream_mesh_file(m.file, m.transform, [&](std::span<const Triangle> batch) {
      buf.assign(batch.begin(), batch.end());
      for (auto& t : buf) t.material = resolve(t.material);
      fn(std::span<const Triangle>(buf));
    });
  }
  ImportStats st;
  TriangleBatcher batcher([&](std::span<const Triangle> batch) {
    st.triangles += batch.size();
    for (const auto& t : batch) st.bounds.extend(t.v0), st.bounds.extend(t.v1), st.bounds.extend(t.v2);
    fn(batch);
  });
  std::vector<std::uint32_t> map;
  for (std::uint32_t s = 0; s < 256; ++s) map.push_back(resolve(s));
  batcher.set_material_map(std::move(map));
  batcher.set_transform(m.transform);
  run_generator(m.generator, m.triangles, m.seed, batcher);
  batcher.flush();
  return st;
}

ImportStats stream_scene(const Scene& scene, const TriangleBatchFn& fn) {
  ImportStats all;
  for (std::size_t i = 0; i < scene.meshes.size(); ++i) {
    const ImportStats s = stream_scene_mesh(scene, i, fn);
    all.triangles += s.triangles, all.skipped_primitives += s.skipped_primitives;
    all.bounds.extend(s.bounds);
  }
  return all;
}

ImportStats scene_stats(const Scene& scene) {
  return stream_scene(scene, [](std::span<const Triangle>) {});
}

}  // namespace rayline::scene
