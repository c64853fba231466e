// blocks.json, the top level `rayline partition` writes beside the block files and
// `rayline render --blocks-dir DIR` reads (partition::load_block_index), then what the
// renderer asks of the index: the cell holding a point and the cells along a ray, which
// walk its kd-tree.
#include <cstddef>
#include <cstdint>

#include "fuzz_support.hpp"
#include "render/partition/partition.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  (void)rayline::fuzz::write_input("blocks.json", data, size);
  rayline::fuzz::expect_clean("block_index", [&] {
    using rayline::scene::Float3;
    const rayline::partition::BlockIndex idx = rayline::partition::load_block_index(rayline::fuzz::scratch_dir().string());
    const Float3 c = (idx.bounds.lo + idx.bounds.hi) * 0.5f;
    for (const Float3 p : {c, idx.bounds.lo, idx.bounds.hi}) (void)idx.locate(p);
    const Float3 dirs[] = {{1, 0, 0}, {0, -1, 0}, {0.3f, 0.5f, -0.8f}};
    for (const Float3 d : dirs) (void)idx.cells_along_ray(idx.bounds.lo - d, d, 0, 1e30f);
  });
  return 0;
}
