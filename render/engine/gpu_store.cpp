#include "render/engine/gpu_store.hpp"

#include <algorithm>
#include <chrono>

#include <tbb/parallel_for.h>

namespace rayline::engine {

using trace::RayKind;
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

void GpuStore::run_job(const trace::TraceSettings& ts, std::uint32_t cell, RayKind kind, std::span<const RayRecord> rays,
                       std::span<const std::pair<BlockId, std::uint32_t>> parts, std::vector<RayRecord>& out,
                       trace::RayCounts& counts) {
  std::shared_ptr<const gpu::GpuBlock> block;
  {
    std::lock_guard lk(mu_);
    if (!lost_)
      if (auto it = blocks_.find(cell); it != blocks_.end()) block = it->second;
  }
  std::size_t off = 0;
  std::vector<gpu::GpuHit> hits;
  std::vector<std::uint8_t> occluded;
  double kernel = 0;
  std::uint64_t on_gpu = 0, doubtful = 0;
  for (const auto& [queue, n] : parts) {
    const std::span<const RayRecord> part = rays.subspan(off, n);
    off += n;
    std::unique_ptr<gpu::GpuRays> up;
    {
      std::lock_guard lk(mu_);
      if (auto it = rays_.find(queue); it != rays_.end()) {
        up = std::move(it->second);
        rays_.erase(it);
      }
    }
    if (block) {
      try {
        if (!up) {  // the T-job failed or was not planned: upload now
          up = pack_upload(part, ts);
          std::lock_guard lk(mu_);
          ++stats_.unplanned_ray_uploads;
        }
        if (kind == RayKind::Path) {
          hits.resize(n);
          kernel += gpu::intersect_closest(ctx_, *block, *up, hits);
        } else {
          occluded.resize(n);
          kernel += gpu::intersect_any(ctx_, *block, *up, occluded);
        }
      } catch (const gpu::GpuError& e) {
        note_error(e);
        block.reset();  // this part and the rest run on the CPU path
      }
    }
    if (!block) {
      // The CPU path: Embree on the RAM copy (loaded on the spot if the plan evicted it).
      const auto geo = ram_.get(cell);
      trace::intersect(ts, *geo, kind, part, out, counts);
      std::lock_guard lk(mu_);
      stats_.fallback_rays += n;
      continue;
    }
    // Shading on the host from the hit triangles the kernel returned (path_kernels.hpp), in
    // parallel chunks (oneTBB) so one host thread does not bound the GPU; chunk outputs are
    // appended in chunk order (the image does not depend on the order anyway). A doubtful
    // ray is not traced here: it goes back as it came, flagged for a CPU device, which
    // traces it with exactly the CPU-only render's arithmetic (Embree + tie filter).
    on_gpu += n;
    constexpr std::size_t kChunk = 2048;
    const std::size_t chunks = (part.size() + kChunk - 1) / kChunk;
    std::vector<std::vector<RayRecord>> chunk_out(chunks);
    std::vector<trace::RayCounts> chunk_counts(chunks);
    std::vector<std::uint64_t> chunk_doubtful(chunks);
    const bool resolve = resolve_doubtful_;
    tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
      std::vector<RayRecord>& o = chunk_out[c];
      trace::RayCounts& k = chunk_counts[c];
      for (std::size_t i = c * kChunk; i < std::min(part.size(), (c + 1) * kChunk); ++i) {
        const RayRecord& r = part[i];
        const bool doubt = kind == RayKind::Path ? gpu::doubtful(hits[i]) : (occluded[i] & gpu::kAnyDoubtful) != 0;
        chunk_doubtful[c] += doubt;
        if (doubt && resolve) {
          o.push_back(r);
          o.back().flags |= trace::kRayCpuOnly;
          continue;
        }
        ++k.traced;
        if (kind == RayKind::Path) {
          const gpu::GpuHit& h = hits[i];
          if (h.prim != gpu::kNoHit) {
            const trace::HitTriangle tri{{h.v[0], h.v[1], h.v[2]}, {h.v[3], h.v[4], h.v[5]}, {h.v[6], h.v[7], h.v[8]},
                                         h.material};
            trace::shade_hit(ts, r, tri, gpu::hit_t(h), o, k);
            continue;
          }
        } else if (occluded[i] & gpu::kAnyOccluded) {
          ++k.occluded;
          continue;
        }
        trace::continue_ray(ts, r, o, k);
      }
    });
    for (std::size_t c = 0; c < chunks; ++c) {
      out.insert(out.end(), chunk_out[c].begin(), chunk_out[c].end());
      counts += chunk_counts[c];
      doubtful += chunk_doubtful[c];
    }
  }
  std::lock_guard lk(mu_);
  stats_.kernel_seconds += kernel;
  stats_.gpu_rays += on_gpu;
  stats_.doubtful_rays += doubtful;
  if (on_gpu == rays.size()) ++stats_.gpu_jobs;
  else ++stats_.fallback_jobs;
}

}  // namespace rayline::engine
