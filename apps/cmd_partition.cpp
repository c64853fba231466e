// `rayline partition`: loads the scene, runs the streaming partitioner and reports the
// time and throughput (distinct scene triangles per second, both passes together).
#include "apps/cmd_partition.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "apps/cli_common.hpp"
#include "render/partition/partition.hpp"
#include "render/scene/scene.hpp"
#include "common/error.hpp"
#include "common/progress_line.hpp"

namespace rayline::cli {

std::function<void(const partition::PartitionProgress&)> partition_progress(ProgressLine& line) {
  return [&line](const partition::PartitionProgress& p) {
    if (!line.due()) return;
    if (p.pass == 1)
      line.print("partition", "pass 1/2 (bounds, sample): %.1f M triangles", double(p.triangles_done) / 1e6);
    else if (p.pass == 2 && p.files_done < p.files_total)
      line.print("partition", "pass 2/2 (blocks): creating %u of %u block files", p.files_done, p.files_total);
    else if (p.pass == 3)
      line.print("partition", "pass 2/2 (blocks): finishing %u of %u block files", p.files_done, p.files_total);
    else
      line.print("partition", "pass 2/2 (blocks): %5.1f %% of %.1f M triangles",
                 100.0 * double(p.triangles_done) / double(std::max<std::uint64_t>(p.triangles_total, 1)),
                 double(p.triangles_total) / 1e6);
  };
}

int run_partition(const PartitionOptions& opt) {
  namespace part = rayline::partition;
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  part::PartitionOptions po;
  po.blocks = opt.blocks;
  po.memory_limit = size_flag("--memory-limit", opt.memory_limit);
  const scene::Scene sc = opt.scene.empty() ? scene::default_scene() : scene::load_scene(opt.scene);

  ProgressLine line(ProgressLine::for_stderr(opt.quiet));
  if (line.mode() != ProgressLine::Mode::Off) po.progress = partition_progress(line);
  ensure_parent_dir(opt.out, "--out");  // its parent; the folder itself appears by rename at the end
  const part::PartitionResult r = part::partition_scene(sc, opt.out, po);
  line.done();
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  const auto& idx = r.index;
  if (!opt.quiet) {
    std::uint64_t lo = UINT64_MAX, hi = 0, bytes = 0;
    for (const auto& b : idx.blocks) lo = std::min(lo, b.triangles), hi = std::max(hi, b.triangles), bytes += b.file_bytes;
    const double mean = double(idx.references) / double(idx.blocks.size());
    std::printf("partitioned %s: %llu triangles into %zu blocks (%s)\n", idx.scene.c_str(),
                static_cast<unsigned long long>(idx.scene_triangles), idx.blocks.size(), r.dir.c_str());
    std::printf("references %llu (%.2f %% duplicated across split planes), %s on disk\n",
                static_cast<unsigned long long>(idx.references),
                100.0 * double(idx.references - idx.scene_triangles) / double(idx.scene_triangles),
                format_size(double(bytes)).c_str());
    std::printf("triangles per block: min %llu, max %llu, mean %.0f (max/mean %.3f)\n",
                static_cast<unsigned long long>(lo), static_cast<unsigned long long>(hi), mean,
                mean > 0 ? double(hi) / mean : 0.0);
    std::printf("pass 1 (bounds, sample of %llu centroids) %s, pass 2 (route, write) %s\n",
                static_cast<unsigned long long>(r.sample_size), format_duration(r.seconds_pass1).c_str(),
                format_duration(r.seconds_pass2).c_str());
  }
  std::printf("time %s, %s\n", format_duration(s).c_str(),
              format_rate(double(idx.scene_triangles) / std::max(s, 1e-9), "triangles").c_str());
  return 0;
}

}  // namespace rayline::cli
