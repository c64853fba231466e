#include "render/store/gpu_store.hpp"

#include <algorithm>

namespace rayline::engine {

using trace::RayRecord;

GpuStore::GpuStore(gpu::GpuContext& ctx, BlockStore& ram) : ctx_(ctx), ram_(ram) {}

void GpuStore::note_error(const gpu::GpuError& e) {
  std::lock_guard lk(mu_);
  if (failure_.empty()) failure_ = e.what();
  if (e.kind() == gpu::GpuErrorKind::DeviceLost || ctx_.lost()) {
    lost_ = true;
    blocks_.clear();
    rays_.clear();
  }
  if (e.kind() == gpu::GpuErrorKind::OutOfMemory) ++stats_.upload_failures;
}

bool GpuStore::lost() const {
  std::lock_guard lk(mu_);
  return lost_;
}

std::string GpuStore::failure() const {
  std::lock_guard lk(mu_);
  return failure_;
}

GpuStoreStats GpuStore::stats() const {
  std::lock_guard lk(mu_);
  return stats_;
}

void GpuStore::load(std::uint32_t cell) {
  {
    std::lock_guard lk(mu_);
    ++copies_[cell];
    if (lost_ || blocks_.count(cell)) return;  // one physical copy for the plan's copies
  }
  // The block comes from its RAM copy (the plan fetched it there first: disk -> RAM -> GPU).
  const auto geo = ram_.get(cell);
  const std::vector<unsigned char> records = geo->records();
  try {
    std::shared_ptr<const gpu::GpuBlock> b = gpu::upload_block(ctx_, records, geo->triangles());
    std::lock_guard lk(mu_);
    ++stats_.block_uploads;
    stats_.block_bytes += b->device_bytes();
    stats_.build_seconds += b->build_seconds;
    stats_.upload_seconds += b->upload_seconds;
    if (copies_[cell] > 0 && !lost_) blocks_[cell] = std::move(b);  // else evicted meanwhile
    stats_.peak_device_bytes = std::max<std::uint64_t>(stats_.peak_device_bytes, ctx_.allocated_bytes());
  } catch (const gpu::GpuError& e) {
    note_error(e);  // the block stays absent: its jobs run on the CPU path
  }
}

void GpuStore::evict(std::uint32_t cell) {
  std::lock_guard lk(mu_);
  auto it = copies_.find(cell);
  if (it == copies_.end() || it->second == 0) return;
  if (--it->second > 0) return;
  if (blocks_.erase(cell)) ++stats_.block_evictions;
}

std::unique_ptr<gpu::GpuRays> GpuStore::pack_upload(std::span<const RayRecord> rays, const trace::TraceSettings& ts) {
  std::vector<gpu::GpuRay> g(rays.size());
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const RayRecord& r = rays[i];
    g[i].org[0] = r.org.x, g[i].org[1] = r.org.y, g[i].org[2] = r.org.z;
    g[i].dir[0] = r.dir.x, g[i].dir[1] = r.dir.y, g[i].dir[2] = r.dir.z;
    trace::query_interval(ts, r, g[i].tmin, g[i].tmax);
  }
  return gpu::upload_rays(ctx_, g);
}

void GpuStore::load_rays(BlockId queue, std::span<const RayRecord> rays, const trace::TraceSettings& ts) {
  if (lost()) return;
  try {
    auto up = pack_upload(rays, ts);
    std::lock_guard lk(mu_);
    ++stats_.ray_uploads;
    stats_.ray_bytes += up->device_bytes();
    if (!lost_) rays_[queue] = std::move(up);
    stats_.peak_device_bytes = std::max<std::uint64_t>(stats_.peak_device_bytes, ctx_.allocated_bytes());
  } catch (const gpu::GpuError& e) {
    note_error(e);  // the E-job uploads again or falls back
  }
}

void GpuStore::drop_rays(BlockId queue) {
  std::lock_guard lk(mu_);
  rays_.erase(queue);
}

std::shared_ptr<const gpu::GpuBlock> GpuStore::resident(std::uint32_t cell) const {
  std::lock_guard lk(mu_);
  if (lost_) return nullptr;
  auto it = blocks_.find(cell);
  return it == blocks_.end() ? nullptr : it->second;
}

std::unique_ptr<gpu::GpuRays> GpuStore::take_rays(BlockId queue) {
  std::lock_guard lk(mu_);
  auto it = rays_.find(queue);
  if (it == rays_.end()) return nullptr;
  std::unique_ptr<gpu::GpuRays> up = std::move(it->second);
  rays_.erase(it);
  return up;
}

std::unique_ptr<gpu::GpuRays> GpuStore::upload_unplanned(std::span<const RayRecord> rays,
                                                         const trace::TraceSettings& ts) {
  auto up = pack_upload(rays, ts);
  std::lock_guard lk(mu_);
  ++stats_.unplanned_ray_uploads;
  return up;
}

void GpuStore::note_job(std::uint64_t rays, std::uint64_t on_gpu, std::uint64_t fallback, std::uint64_t doubtful,
                        double kernel_seconds) {
  std::lock_guard lk(mu_);
  stats_.fallback_rays += fallback;
  stats_.kernel_seconds += kernel_seconds;
  stats_.gpu_rays += on_gpu;
  stats_.doubtful_rays += doubtful;
  if (on_gpu == rays) ++stats_.gpu_jobs;
  else ++stats_.fallback_jobs;
}

}  // namespace rayline::engine
