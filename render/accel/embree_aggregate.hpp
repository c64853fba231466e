// The CPU aggregate (aggregate.hpp): Embree on the RAM copy of the job's block
// (render/embree/embree_kernels.hpp). Every CPU thread of the DCG shares the RAM memory
// device, so one aggregate serves them all.
#pragma once
#include "render/accel/aggregate.hpp"
#include "render/store/block_store.hpp"

namespace rayline::accel {

class EmbreeAggregate final : public Aggregate {
 public:
  // The block is taken from `ram`: resident there by a planned T-job, or loaded on the spot
  // (a plan violation, counted) so the image stays right.
  explicit EmbreeAggregate(engine::BlockStore& ram) : ram_(ram) {}

  void intersect_closest(const trace::TraceSettings& ts, const QueueJob& job, std::vector<trace::RayRecord>& out,
                         trace::RayCounts& counts) override;
  void intersect_shadow(const trace::TraceSettings& ts, const QueueJob& job, std::vector<trace::RayRecord>& out,
                        trace::RayCounts& counts) override;
  bool traces_in_place() const override { return true; }

 private:
  engine::BlockStore& ram_;
};

}  // namespace rayline::accel
