// `rayline partition --scene F --blocks N --out DIR`: split a scene into N spatially
// coherent blocks on disk by a streaming median-split kd-tree (format in
// render/partition/block_file.hpp and partition.hpp).
#pragma once
#include <cstdint>
#include <functional>
#include <string>

namespace rayline {
class ProgressLine;
namespace partition {
struct PartitionProgress;
}
}  // namespace rayline

namespace rayline::cli {

struct PartitionOptions {
  std::string scene;               // scene JSON or bare mesh; empty: the built-in scene
  std::uint32_t blocks = 64;
  std::string out = "out/blocks";
  std::string memory_limit = "1GiB";  // bound on sample + block buffers
  bool quiet = false;
};
int run_partition(const PartitionOptions& opt);

// The partitioner's progress as lines of `line` (partition, and render's own partition).
std::function<void(const partition::PartitionProgress&)> partition_progress(ProgressLine& line);

}  // namespace rayline::cli
