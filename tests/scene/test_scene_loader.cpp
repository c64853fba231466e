// Scene JSON: a full scene loads; every bad input names file and field; camera paths
// interpolate; a bare mesh file becomes a framed scene; the built-in default works.
#include <gtest/gtest.h>

#include "render/scene/scene.hpp"
#include "render/scene/scene_stream.hpp"
#include "scene_fixture.hpp"
#include "common/error.hpp"

namespace rayline::scene {
namespace {

class Loader : public testing::TempDir {
 protected:
  std::string good() const {
    return R"({
  "version": 1,
  "materials": {"white": {"albedo": [0.8, 0.8, 0.8]}, "lamp": {"albedo": 0, "emission": [5, 5, 5]}},
  "meshes": [
    {"name": "tri", "file": "tri.obj", "material": "white",
     "transform": {"scale": 2, "rotate": {"axis": [0, 1, 0], "deg": 90}, "translate": [0, 1, 0]}},
    {"name": "box", "generator": "cornell", "triangles": 1000, "seed": 3, "material_slots": ["white", "lamp"]}
  ],
  "lights": [
    {"type": "area", "name": "key", "corner": [0, 2, 0], "edge_u": [1, 0, 0], "edge_v": [0, 0, 1], "emission": 10},
    {"type": "environment", "radiance": [0.1, 0.2, 0.3]}
  ],
  "cameras": {"main": {"position": [0, 1, 5], "look_at": [0, 1, 0], "fov_deg": 50, "resolution": [320, 240]},
              "top": {"position": [0, 10, 0.1], "look_at": [0, 0, 0]}},
  "camera_paths": {"move": {"frames": 5, "interpolation": "linear",
                            "keys": [{"t": 0, "camera": "main"}, {"t": 2, "position": [4, 1, 5], "look_at": [0, 1, 0]}]}},
  "render": {"spp": 8, "max_depth": 3}
})";
  }
  void SetUp() override {
    TempDir::SetUp();
    write("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  }
  // Replaces the first occurrence of `from` in the good scene and expects an error on `field`.
  void expect_field_error(const std::string& from, const std::string& to, const std::string& field) {
    std::string s = good();
    const auto pos = s.find(from);
    ASSERT_NE(pos, std::string::npos) << from;
    s.replace(pos, from.size(), to);
    const auto p = write("bad.json", s);
    try {
      load_scene(p);
      ADD_FAILURE() << "no error for " << to;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), p);
      EXPECT_EQ(e.field(), field) << e.what();
    }
  }
};

TEST_F(Loader, GoodSceneLoads) {
  const Scene s = load_scene(write("s.json", good()));
  ASSERT_EQ(s.materials.size(), 3u);  // + "default" for the mesh without "material"
  EXPECT_EQ(s.materials[2].name, "default");
  EXPECT_EQ(s.materials[1].emission, (Float3{5, 5, 5}));
  ASSERT_EQ(s.meshes.size(), 2u);
  EXPECT_EQ(s.meshes[0].file, path("tri.obj"));
  EXPECT_EQ(s.meshes[1].generator, "cornell");
  EXPECT_EQ(s.meshes[1].material_slots, (std::vector<std::uint32_t>{0, 1}));
  EXPECT_EQ(s.area_lights.size(), 1u);
  EXPECT_FLOAT_EQ(s.environment.radiance.z, 0.3f);
  EXPECT_EQ(s.default_camera().name, "main");
  EXPECT_EQ(s.default_camera().width, 320);
  EXPECT_EQ(s.render.spp, 8);
  // Transform: scale 2, rotate 90° about y, translate y+1: (1,0,0) → (0,1,-2).
  const Float3 p = s.meshes[0].transform.point({1, 0, 0});
  EXPECT_NEAR(p.x, 0, 1e-5f); EXPECT_NEAR(p.y, 1, 1e-5f); EXPECT_NEAR(p.z, -2, 1e-5f);
  // Streaming: 1 triangle from the file + 1000 from the generator, material ids remapped.
  std::uint64_t n = 0, white = 0;
  const ImportStats st = stream_scene(s, [&](std::span<const Triangle> b) {
    n += b.size();
    for (auto& t : b) white += t.material == 0;
  });
  EXPECT_EQ(n, 1001u);
  EXPECT_EQ(st.triangles, 1001u);
  EXPECT_GT(white, 0u);
}

TEST_F(Loader, CameraPathInterpolates) {
  const Scene s = load_scene(write("s.json", good()));
  const CameraPath& p = s.camera_paths.at(0);
  EXPECT_EQ(p.frames, 5);
  EXPECT_NEAR(p.at_frame(0).position.x, 0, 1e-6f);
  EXPECT_NEAR(p.at_frame(2).position.x, 2, 1e-6f);
  EXPECT_NEAR(p.at_frame(4).position.x, 4, 1e-6f);
  EXPECT_EQ(p.at_frame(4).width, 320);
}

TEST_F(Loader, CatmullRomPassesThroughKeys) {
  CameraPath p;
  p.name = "c", p.frames = 7, p.interpolation = Interpolation::catmull_rom;
  for (int k = 0; k < 4; ++k) {
    CameraKey key{double(k), Camera{}};
    key.camera.position = {float(k * k), 0, 5};
    p.keys.push_back(key);
  }
  EXPECT_NEAR(p.at_frame(0).position.x, 0, 1e-5f);
  EXPECT_NEAR(p.at_frame(2).position.x, 1, 1e-5f);  // t = 1
  EXPECT_NEAR(p.at_frame(4).position.x, 4, 1e-5f);  // t = 2
  EXPECT_NEAR(p.at_frame(6).position.x, 9, 1e-5f);
}

TEST_F(Loader, DanglingReferences) {
  expect_field_error(R"("material": "white")", R"("material": "chalk")", "meshes[0].material");
  expect_field_error(R"(["white", "lamp"])", R"(["white", "lava"])", "meshes[1].material_slots[1]");
  expect_field_error(R"({"t": 0, "camera": "main"})", R"({"t": 0, "camera": "side"})",
                     "camera_paths.move.keys[0].camera");
  expect_field_error(R"("file": "tri.obj")", R"("file": "gone.obj")", "meshes[0].file");
  expect_field_error(R"("generator": "cornell")", R"("generator": "sponza")", "meshes[1].generator");
}

TEST_F(Loader, OutOfRangeValues) {
  expect_field_error(R"("albedo": [0.8, 0.8, 0.8])", R"("albedo": [0.8, 1.2, 0.8])", "materials.white.albedo");
  expect_field_error(R"("albedo": [0.8, 0.8, 0.8])", R"("albedo": [-0.1, 0.8, 0.8])", "materials.white.albedo");
  expect_field_error(R"("emission": [5, 5, 5])", R"("emission": [5, -1, 5])", "materials.lamp.emission");
  expect_field_error(R"("fov_deg": 50)", R"("fov_deg": 180)", "cameras.main.fov_deg");
  expect_field_error(R"("resolution": [320, 240])", R"("resolution": [0, 240])", "cameras.main.resolution");
  expect_field_error(R"("frames": 5)", R"("frames": 0)", "camera_paths.move.frames");
  expect_field_error(R"({"t": 2,)", R"({"t": 0,)", "camera_paths.move.keys[1].t");
  expect_field_error(R"("triangles": 1000)", R"("triangles": -4)", "meshes[1].triangles");
  expect_field_error(R"("edge_v": [0, 0, 1])", R"("edge_v": [2, 0, 0])", "lights[0]");
  expect_field_error(R"("spp": 8)", R"("spp": 0)", "render.spp");
  expect_field_error(R"("radiance": [0.1, 0.2, 0.3])", R"("radiance": [0.1, -0.2, 0.3])", "environment.radiance");
}

TEST_F(Loader, UnknownFieldsAndTypes) {
  expect_field_error(R"("render": {)", R"("rendr": {)", "rendr");
  expect_field_error(R"("fov_deg": 50)", R"("fov": 50)", "cameras.main.fov");
  expect_field_error(R"("type": "area")", R"("type": "spot")", "lights[0].type");
  expect_field_error(R"("interpolation": "linear")", R"("interpolation": "cubic")",
                     "camera_paths.move.interpolation");
  expect_field_error(R"("position": [0, 1, 5])", R"("position": [0, 1])", "cameras.main.position");
}

TEST_F(Loader, InvalidJsonAndMissingFile) {
  EXPECT_THROW(load_scene(write("broken.json", "{\"meshes\": [")), InputError);
  EXPECT_THROW(load_scene(path("absent.json")), InputError);
  EXPECT_THROW(load_scene(write("notes.txt", "hello")), InputError);
}

TEST_F(Loader, BareMeshIsFramed) {
  const auto p = write("bunny.obj", "v -1 0 0\nv 1 0 0\nv 0 2 0\nv 0 0 3\nf 1 2 3\nf 1 2 4\n");
  const Scene s = load_scene(p);
  ASSERT_EQ(s.meshes.size(), 1u);
  EXPECT_EQ(s.meshes[0].file, p);
  ASSERT_FALSE(s.cameras.empty());
  const Camera& c = s.default_camera();
  EXPECT_NEAR(c.look_at.y, 1, 1e-5f);
  EXPECT_GT(length(c.position - c.look_at), 2.0f);
  EXPECT_EQ(s.area_lights.size(), 1u);
  EXPECT_GT(s.environment.radiance.x, 0);
  EXPECT_GT(s.area_lights[0].corner.y, 2.0f);
  // The key light shines down onto the mesh: it emits along edge_u x edge_v.
  EXPECT_LT(cross(s.area_lights[0].edge_u, s.area_lights[0].edge_v).y, 0.0f);
  EXPECT_EQ(scene_stats(s).triangles, 2u);
}

TEST_F(Loader, DefaultSceneIsBuiltIn) {
  const Scene s = default_scene();
  EXPECT_NO_THROW(validate(s));
  EXPECT_EQ(s.meshes.at(0).generator, "cornell");
  const ImportStats st = scene_stats(s);
  EXPECT_EQ(st.triangles, 10000u);
  EXPECT_GE(st.bounds.lo.x, -1e-5f);
  EXPECT_LE(st.bounds.hi.y, 1 + 1e-5f);
}

TEST_F(Loader, JsonRoundTrip) {
  const Scene a = load_scene(write("s.json", good()));
  const std::string text = scene_to_json(a, dir_.string());
  const Scene b = parse_scene(text, path("copy.json"));
  EXPECT_EQ(b.meshes[0].file, a.meshes[0].file);
  EXPECT_EQ(b.meshes[0].transform, a.meshes[0].transform);
  EXPECT_EQ(b.materials.size(), a.materials.size());
  EXPECT_EQ(b.cameras.size(), a.cameras.size());
  EXPECT_EQ(b.camera_paths.at(0).keys.size(), 2u);
  EXPECT_EQ(scene_to_json(b, dir_.string()), text);
}

TEST(SceneFiles, CommittedScenesLoad) {
  for (const auto& e : std::filesystem::directory_iterator(RAYLINE_SCENES_DIR)) {
    if (e.path().extension() != ".json") continue;
    // Scene profiles of the simulator (*.profile.json, docs/scene-profiles.md) live here too.
    if (e.path().stem().extension() == ".profile") continue;
    SCOPED_TRACE(e.path().string());
    EXPECT_NO_THROW(load_scene(e.path().string()));
  }
}

}  // namespace
}  // namespace rayline::scene
