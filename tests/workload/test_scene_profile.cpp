// Scene profiles (docs/scene-profiles.md): the committed paper-scale profiles load and have
// the paper's block counts and footprints (Table 1); bad files name the file and field.
#include <gtest/gtest.h>

#include <cmath>

#include "common/error.hpp"
#include "workload/scene_profile.hpp"

using namespace rayline;

namespace {
const std::string kData = std::string(RAYLINE_TEST_DATA) + "/profiles/";
const std::string kScenes = std::string(RAYLINE_SCENES_DIR) + "/";

std::string error_of(const std::string& file) {
  try {
    load_scene_profile(file);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(SceneProfile, SmallFixtureLoads) {
  const SceneProfile p = load_scene_profile(kData + "small.profile.json");
  EXPECT_EQ(p.blocks.size(), 8u);
  EXPECT_EQ(p.tiles(), 12);
  std::uint64_t px = 0;
  for (int t = 0; t < p.tiles(); ++t) px += p.tile_pixels(t);
  EXPECT_EQ(px, 64u * 48u);
  EXPECT_EQ(p.camera_path.size(), 2u);
}

TEST(SceneProfile, PaperScaleProfilesMatchTable1) {
  const SceneProfile b = load_scene_profile(kScenes + "boeing.profile.json");
  EXPECT_EQ(b.blocks.size(), 129u);
  EXPECT_EQ(b.scene_bytes(), static_cast<Bytes>(std::llround(26.5 * 1024 * 1024 * 1024)));
  EXPECT_EQ(b.width, 512);
  EXPECT_EQ(b.spp, 4);
  const SceneProfile m = load_scene_profile(kScenes + "museum.profile.json");
  EXPECT_EQ(m.blocks.size(), 65u);
  EXPECT_EQ(m.scene_bytes(), static_cast<Bytes>(std::llround(12.3 * 1024 * 1024 * 1024)));
  EXPECT_EQ(m.width, 2048);
  EXPECT_EQ(m.spp, 128);
  for (const SceneProfile* p : {&b, &m})
    for (const ProfileBlock& blk : p->blocks) {
      double s = 0;
      for (const ProfileNeighbour& n : blk.neighbours) s += n.p;
      if (!blk.neighbours.empty()) {
        EXPECT_NEAR(s, 1.0, 1e-6);
      }
    }
}

TEST(SceneProfile, WrongBlockCountIsNamed) {
  const std::string e = error_of(kData + "bad-block-count.profile.json");
  EXPECT_NE(e.find("bad-block-count.profile.json: block_count"), std::string::npos) << e;
}

TEST(SceneProfile, ProbabilitiesNotSummingToOneAreNamed) {
  const std::string e = error_of(kData + "bad-probabilities.profile.json");
  EXPECT_NE(e.find("blocks[3].neighbours"), std::string::npos) << e;
  EXPECT_NE(e.find("not 1"), std::string::npos) << e;
}

TEST(SceneProfile, NegativeSizeIsNamed) {
  const std::string e = error_of(kData + "bad-negative-size.profile.json");
  EXPECT_NE(e.find("blocks[2].bytes"), std::string::npos) << e;
}

TEST(SceneProfile, UnknownNeighbourIsNamed) {
  const std::string e = error_of(kData + "bad-unknown-neighbour.profile.json");
  EXPECT_NE(e.find("blocks[1].neighbours[1]"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown block 42"), std::string::npos) << e;
}

TEST(SceneProfile, InlineErrors) {
  auto err = [](const std::string& text) {
    try {
      parse_scene_profile(text, "x.profile.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(err("{").find("invalid JSON"), std::string::npos);
  EXPECT_NE(err(R"({"format":"rayline-scene-profile","version":1,"bogus":1})").find("bogus: unknown key"), std::string::npos);
  const std::string one =
      R"({"format":"rayline-scene-profile","version":1,"block_count":1,"blocks":[{"bytes":10,"lo":[0,0,0],"hi":[1,1,1],)"
      R"("alpha":0.5,"beta":0.5,"escape":1,"shadow_occlusion":0.1,"shadow_exit":0,"neighbours":[]}],)"
      R"("camera_path":[{"background":0.5,"entry":[[0,0.4]]}]})";
  EXPECT_NE(err(one).find("camera_path[0].entry: background + entry probabilities sum to"), std::string::npos) << err(one);
  // Found by mutation fuzzing: wrong types in the header fields escaped as nlohmann's
  // type_error (exit 1, no file or field).
  EXPECT_NE(err(R"({"format":"rayline-scene-profile","version":"1"})").find("x.profile.json: version: expected 1"), std::string::npos);
  EXPECT_NE(err(R"({"format":"rayline-scene-profile","version":1.5})").find("version: expected 1"), std::string::npos);
  EXPECT_NE(err(R"({"format":7,"version":1})").find("x.profile.json: format: expected a string"), std::string::npos);
  EXPECT_NE(err(R"({"format":"rayline-scene-profile","version":1,"provenance":-1})").find("provenance: expected a string"),
            std::string::npos);
  EXPECT_NE(err(R"({"format":"rayline-scene-profile","version":1,"name":[]})").find("name: expected a string"), std::string::npos);
}
