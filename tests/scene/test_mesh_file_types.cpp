// A path given as a mesh that is not a regular file: the error names the file and says
// what it is (file_type.hpp), and a FIFO never blocks the reader.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "common/error.hpp"
#include "render/scene/file_type.hpp"
#include "render/scene/mesh_import.hpp"
#include "render/scene/scene.hpp"
#include "scene_fixture.hpp"

namespace rayline::scene {
namespace {

class MeshFileTypes : public testing::TempDir {
 protected:
  static std::string import_error(const std::string& file) {
    try {
      mesh_file_stats(file);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }
};

TEST_F(MeshFileTypes, EachKindIsNamed) {
  namespace fs = std::filesystem;
  fs::create_symlink("loop_b.obj", path("loop_a.obj"));
  fs::create_symlink("loop_a.obj", path("loop_b.obj"));
  fs::create_symlink("missing.obj", path("dangling.obj"));
  fs::create_directory(path("folder.obj"));
  ASSERT_EQ(::mkfifo(path("pipe.obj").c_str(), 0600), 0);
  const std::string good = write("good.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  fs::create_symlink("good.obj", path("link.obj"));

  // Opening the FIFO for reading would wait for a writer: end the test, not the suite.
  ::alarm(20);
  const std::pair<const char*, const char*> cases[] = {
      {"loop_a.obj", "symbolic link loop"}, {"dangling.obj", "symbolic link to a missing file"},
      {"folder.obj", "is a folder"},        {"pipe.obj", "is a FIFO"},
      {"absent.obj", "does not exist"},
  };
  for (const auto& [name, says] : cases) {
    const std::string msg = import_error(path(name));
    EXPECT_NE(msg.find(name), std::string::npos) << msg;
    EXPECT_NE(msg.find(says), std::string::npos) << msg;
  }
  ::alarm(0);
  EXPECT_EQ(import_error(good), "");
  EXPECT_EQ(import_error(path("link.obj")), "");  // a link to a regular file is one
  EXPECT_EQ(not_a_regular_file(good, "mesh file"), "");
  EXPECT_EQ(not_a_regular_file(path("folder.obj"), "scene file"), "is a folder, not a scene file (give the file's path)");
}

// The same for a scene file given as --scene, and for a mesh a scene JSON names: a FIFO
// must not block load_scene, a link loop is named as one.
TEST_F(MeshFileTypes, SceneFilesAndTheMeshesTheyNameAreNamedToo) {
  namespace fs = std::filesystem;
  fs::create_symlink("loop_b.json", path("loop_a.json"));
  fs::create_symlink("loop_a.json", path("loop_b.json"));
  ASSERT_EQ(::mkfifo(path("pipe.json").c_str(), 0600), 0);
  ASSERT_EQ(::mkfifo(path("pipe.obj").c_str(), 0600), 0);
  const std::string scene = write("scene.json", R"({"meshes": [{"file": "pipe.obj"}]})");
  auto load_error = [](const std::string& file) {
    try {
      load_scene(file);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  ::alarm(20);
  EXPECT_NE(load_error(path("loop_a.json")).find("symbolic link loop"), std::string::npos);
  EXPECT_NE(load_error(path("pipe.json")).find("is a FIFO"), std::string::npos);
  const std::string msg = load_error(scene);
  ::alarm(0);
  EXPECT_NE(msg.find("meshes[0].file"), std::string::npos) << msg;
  EXPECT_NE(msg.find("is a FIFO"), std::string::npos) << msg;
  EXPECT_NE(load_error(path("absent.json")).find("scene file does not exist"), std::string::npos);
}

}  // namespace
}  // namespace rayline::scene
