// blocks.json (partition::load_block_index), read by `rayline render --blocks-dir`: a file
// the user can edit or damage. Found by its fuzz target (tests/fuzz/fuzz_block_index.cpp):
// JSON nested 100 000 levels deep overflowed the stack while parsing, and numbers were
// converted without a range check (1e20 converted to an int is undefined behaviour).
// Also refused now: a kd-tree that is not a tree, and block file names that leave the
// folder. Each is an InputError naming blocks.json and the field.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "common/error.hpp"
#include "render/partition/partition.hpp"

namespace fs = std::filesystem;
using rayline::InputError;
using rayline::partition::load_block_index;

namespace {

class BlockIndexFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rayline-block-index-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The InputError's field for blocks.json = `text`; "(none)" when it loads.
  std::string field_of(const std::string& text) const {
    std::ofstream(dir_ / "blocks.json", std::ios::binary) << text;
    try {
      load_block_index(dir_.string());
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), (dir_ / "blocks.json").string()) << e.what();
      return e.field();
    }
    return "(none)";
  }
  fs::path dir_;
};

const std::string kBlock0 =
    R"({"id": 0, "file": "block_00000.rlb", "triangles": 2, "bytes": 208, "payload_crc32": 7,
        "cell": {"lo": [0, 0, 0], "hi": [1, 1, 1]}, "geometry_bounds": null, "neighbours": []})";
const std::string kBlock1 =
    R"({"id": 1, "file": "block_00001.rlb", "triangles": 0, "bytes": 128, "payload_crc32": 0,
        "cell": {"lo": [1, 0, 0], "hi": [2, 1, 1]}, "geometry_bounds": null, "neighbours": [{"block": 0, "axis": 0, "area": 1}]})";
const std::string kBlock2 =
    R"({"id": 2, "file": "block_00002.rlb", "triangles": 0, "bytes": 128, "payload_crc32": 0,
        "cell": {"lo": [1, 0, 0], "hi": [2, 1, 1]}, "geometry_bounds": null, "neighbours": []})";

// A three-block index whose kd-tree nodes are `nodes`.
std::string index_with(const std::string& nodes, const std::string& version = "1") {
  return R"({"format": "rayline-blocks", "version": )" + version +
         R"(, "scene": "s", "scene_triangles": 2, "references": 2,
             "bounds": {"lo": [0, 0, 0], "hi": [2, 1, 1]}, "kdtree": {"root": 0, "nodes": )" + nodes +
         R"(}, "blocks": [)" + kBlock0 + ", " + kBlock1 + ", " + kBlock2 + "]}";
}

const std::string kTree =
    R"([{"axis": 0, "split": 1, "left": 1, "right": 2}, {"block": 0},
        {"axis": 1, "split": 0.5, "left": 3, "right": 4}, {"block": 1}, {"block": 2}])";

}  // namespace

TEST_F(BlockIndexFile, AValidIndexLoads) {
  EXPECT_EQ(field_of(index_with(kTree)), "(none)");
  const auto idx = load_block_index(dir_.string());
  ASSERT_EQ(idx.blocks.size(), 3u);
  EXPECT_EQ(idx.locate({1.5f, 0.75f, 0.5f}), 2u);
  EXPECT_EQ(idx.blocks[1].neighbours.size(), 1u);
}

TEST_F(BlockIndexFile, HostileJsonIsAnInputError) {
  EXPECT_EQ(field_of(std::string(100000, '[') + std::string(100000, ']')), "");
  EXPECT_EQ(field_of("{\"blocks\": " + std::string(100000, '[') + std::string(100000, ']') + "}"), "");
  EXPECT_EQ(field_of(index_with(kTree, "1e400")), "");
  EXPECT_EQ(field_of("[1, 2]"), "");
}

TEST_F(BlockIndexFile, NumbersOutOfRangeAreRefusedBeforeAnyConversion) {
  EXPECT_EQ(field_of(index_with(kTree, "1e20")), "version");
  EXPECT_EQ(field_of(index_with(kTree, "1.5")), "version");
  std::string t = kTree;
  EXPECT_EQ(field_of(index_with(t.replace(t.find("\"axis\": 0"), 9, "\"axis\": 1e20"))), "kdtree.nodes[0].axis");
  t = kTree;
  EXPECT_EQ(field_of(index_with(t.replace(t.find("\"split\": 1"), 10, "\"split\": 1e39"))), "kdtree.nodes[0].split");
  t = kTree;
  EXPECT_EQ(field_of(index_with(t.replace(t.find("\"left\": 1"), 9, "\"left\": -1"))), "kdtree.nodes[0].left");
  std::string text = index_with(kTree);
  EXPECT_EQ(field_of(text.replace(text.find("\"payload_crc32\": 7"), 18, "\"payload_crc32\": 4294967296")),
            "blocks[0].payload_crc32");
  text = index_with(kTree);
  EXPECT_EQ(field_of(text.replace(text.find("\"hi\": [2, 1, 1]"), 15, "\"hi\": [2, 1e39, 1]")), "bounds.hi[1]");
  text = index_with(kTree);
  EXPECT_EQ(field_of(text.replace(text.find("\"hi\": [1, 1, 1]"), 15, "\"hi\": [-1, 1, 1]")), "blocks[0].cell");
}

// The renderer walks the tree the file describes: with a node reached twice (two parents,
// or a parent naming one child twice) its cell depends on which parent came last, and a
// block that is the leaf of two nodes, or of none, renders wrong without a word.
TEST_F(BlockIndexFile, TheKdTreeMustBeATree) {
  EXPECT_EQ(field_of(index_with(R"([{"axis": 0, "split": 1, "left": 1, "right": 1}, {"block": 0},
                                     {"block": 1}, {"block": 2}, {"block": 2}])")),
            "kdtree.nodes[0]");
  EXPECT_EQ(field_of(index_with(R"([{"axis": 0, "split": 1, "left": 1, "right": 2},
                                     {"axis": 1, "split": 0.5, "left": 3, "right": 4},
                                     {"axis": 1, "split": 0.5, "left": 3, "right": 4}, {"block": 0}, {"block": 1}])")),
            "kdtree.nodes[2]");
  EXPECT_EQ(field_of(index_with(R"([{"axis": 0, "split": 1, "left": 1, "right": 2}, {"block": 0},
                                     {"axis": 1, "split": 0.5, "left": 3, "right": 4}, {"block": 1}, {"block": 1}])")),
            "kdtree.nodes[4].block");
  EXPECT_EQ(field_of(index_with(R"([{"axis": 0, "split": 1, "left": 2, "right": 1}, {"block": 0},
                                     {"axis": 1, "split": 0.5, "left": 1, "right": 4}, {"block": 1}, {"block": 2}])")),
            "kdtree.nodes[2]");
  EXPECT_EQ(field_of(index_with(R"([{"block": 0}])")), "kdtree.nodes");
}

TEST_F(BlockIndexFile, BlockFileNamesStayInTheFolder) {
  for (const char* name : {"..", ".", "", "sub/block.rlb", "/etc/passwd"}) {
    std::string text = index_with(kTree);
    text.replace(text.find("block_00000.rlb"), 15, name);
    EXPECT_EQ(field_of(text), "blocks[0].file") << name;
  }
}
