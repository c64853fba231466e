#include "sched/policy/input_summary.hpp"

namespace rayline {

const InputSummaries::Summary& InputSummaries::of(JobId j, const JobPool& pool) {
  if (s_.size() < pool.job_count()) s_.resize(pool.job_count());
  Summary& in = s_[static_cast<std::size_t>(j)];
  const std::vector<BlockId>& all = pool.job(j).inputs;
  for (; in.seen < all.size(); ++in.seen) {
    const BlockId b = all[in.seen];
    const DataBlock& blk = pool.block(b);
    if (blk.kind == DataKind::SceneData) in.scene.push_back(b);
    else if (blk.consumed) in.fixed_rays += blk.bytes;
    else in.live.push_back(b);
  }
  return in;
}

}  // namespace rayline
