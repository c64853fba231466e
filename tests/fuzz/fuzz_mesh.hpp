// The path a bare mesh file takes through the command line, shared by the mesh targets:
// `rayline render --scene MESH` / `partition --scene MESH` load it as a scene framing the
// mesh (load_scene: one streaming pass through mesh_import.cpp, then the camera placed on
// its bounds), partition it (a second streaming pass; cells and occupancy grids sized by
// its bounds) and read the blocks back as `render --blocks-dir` does.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.hpp"
#include "render/partition/block_file.hpp"
#include "render/partition/partition.hpp"
#include "render/scene/scene.hpp"

namespace rayline::fuzz {

// With `partition` false only the first step runs: load_scene, one streaming pass.
inline void run_mesh_file(const char* target, const std::string& file_name, const std::uint8_t* data,
                          std::size_t size, bool partition = true) {
  const std::string path = write_input(file_name, data, size);
  const std::string blocks = (scratch_dir() / "blocks").string();
  expect_clean(target, [&] {
    const scene::Scene sc = scene::load_scene(path);
    if (!partition) return;
    partition::PartitionOptions po;
    po.blocks = 4;
    po.memory_limit = std::uint64_t(16) << 20;  // the smallest bound `partition` accepts
    remove_path(blocks);
    partition::partition_scene(sc, blocks, po);
    const partition::BlockIndex idx = partition::load_block_index(blocks);
    for (const partition::BlockInfo& b : idx.blocks) (void)partition::read_block(blocks + "/" + b.file);
  });
  remove_path(blocks);
}

}  // namespace rayline::fuzz
