#include "render/engine/aggregate_factory.hpp"

#include "render/accel/embree_aggregate.hpp"
#include "render/accel/vulkan_aggregate.hpp"
#include "render/engine/profile_recorder.hpp"
#include "render/store/block_store.hpp"
#include "render/store/gpu_store.hpp"

namespace rayline::engine {

namespace {

// The CPU aggregate while a ProfileRecorder records: the same Embree kernels, one ray at a
// time, so the recorder sees what became of every ray (the image is unchanged).
class RecordingAggregate final : public accel::Aggregate {
 public:
  RecordingAggregate(ProfileRecorder& recorder, BlockStore& ram) : recorder_(recorder), ram_(ram) {}
  void intersect_closest(const trace::TraceSettings& ts, const accel::QueueJob& job,
                         std::vector<trace::RayRecord>& out, trace::RayCounts& counts) override {
    record(ts, job, out, counts);
  }
  void intersect_shadow(const trace::TraceSettings& ts, const accel::QueueJob& job,
                        std::vector<trace::RayRecord>& out, trace::RayCounts& counts) override {
    record(ts, job, out, counts);
  }

 private:
  void record(const trace::TraceSettings& ts, const accel::QueueJob& job, std::vector<trace::RayRecord>& out,
              trace::RayCounts& counts) {
    const auto geo = ram_.get(job.cell);
    recorder_.trace_job(ts, *geo, job.cell, job.rays, out, counts);
  }
  ProfileRecorder& recorder_;
  BlockStore& ram_;
};

}  // namespace

std::unique_ptr<accel::Aggregate> make_aggregate(ComputeKind kind, const AggregateSources& sources) {
  if (kind == ComputeKind::Gpu && sources.gpu)
    return std::make_unique<accel::VulkanAggregate>(*sources.gpu, sources.ram, sources.resolve_doubtful);
  if (sources.recorder) return std::make_unique<RecordingAggregate>(*sources.recorder, sources.ram);
  return std::make_unique<accel::EmbreeAggregate>(sources.ram);
}

}  // namespace rayline::engine
