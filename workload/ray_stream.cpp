#include "workload/ray_stream.hpp"

#include <algorithm>
#include <cmath>

#include "common/error.hpp"

namespace rayline {

RayStreamWorkload::RayStreamWorkload(const DeviceGraph& g, RayStreamOptions opt)
    : g_(g), opt_(opt), state_(opt.seed * 0x9E3779B97F4A7C15ull + 1) {
  type_ = g.job_type("RayIntersect");
  if (type_ == kNone) throw InputError(g.source_file, "job_types", "the ray stream needs job type 'RayIntersect'");
  for (std::size_t m = 0; m < g.memories.size(); ++m) {
    if (g.memories[m].kind == MemoryKind::Host) hosts_.push_back(static_cast<MemId>(m));
    if (g.memories[m].kind == MemoryKind::Disk) disks_.push_back(static_cast<MemId>(m));
  }
  if (hosts_.empty() || disks_.empty()) throw InputError(g.source_file, "memory", "the ray stream needs a disk and a host memory");
  if (opt_.blocks < 1) throw InputError("--blocks", "", "must be >= 1");
  if (opt_.backlog <= 0) opt_.backlog = 2 * static_cast<int>(g.computes.size());
  // Every block must fit some memory device a compute device works from, or nothing runs.
  Bytes largest = 0;
  for (const ComputeDevice& d : g.computes) largest = std::max(largest, g.memories[d.memory].capacity);
  const double block = static_cast<double>(opt_.scene_bytes) / opt_.blocks * 1.1;  // blocks vary by +-10 %
  if (block > static_cast<double>(largest))
    throw InputError("--blocks", "", std::to_string(opt_.blocks) + " blocks of a " + std::to_string(opt_.scene_bytes >> 20) +
                                         " MiB scene are up to " + std::to_string(static_cast<Bytes>(block) >> 20) +
                                         " MiB each, larger than every memory device a compute device can use (" +
                                         std::to_string(largest >> 20) + " MiB in " + g.source_file + "); use more blocks");
}

double RayStreamWorkload::uniform() {  // splitmix64 -> [0, 1)
  std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * (1.0 / 9007199254740992.0);
}

void RayStreamWorkload::start(Time now, JobPool& pool, Schedule& s) {
  for (int b = 0; b < opt_.blocks; ++b) {
    DataBlock d;
    d.name = "scene" + std::to_string(b);
    d.kind = DataKind::SceneData;
    d.bytes = static_cast<Bytes>(static_cast<double>(opt_.scene_bytes) / opt_.blocks * (0.9 + 0.2 * uniform()));
    const BlockId id = pool.add_block(d);
    scene_.push_back(id);
    for (MemId m : disks_) s.put_initial(id, m, now, true);  // Sec. 6.1: a full copy per node
  }
  if (opt_.warm) {  // popularity: the Zipf weights top_up draws blocks with
    std::vector<double> use(scene_.size());
    for (std::size_t b = 0; b < use.size(); ++b) use[b] = 1.0 / static_cast<double>(b + 1);
    warm_start(s, pool, scene_, use, opt_.warm_start);
  }
  top_up(now, pool, s);
}

BlockId RayStreamWorkload::new_queue_block(int block, std::uint64_t rays, JobPool& pool) {
  DataBlock q;
  q.name = "rays" + std::to_string(pool.block_count());
  q.kind = DataKind::RayQueue;
  q.consumed = true;
  q.bytes = rays * opt_.ray_bytes;
  q.scene_block = scene_[static_cast<std::size_t>(block)];
  return pool.add_block(q);
}

// A queue of `rays` for `block` now sits on `where` (new, or the output `produced`).
void RayStreamWorkload::add_queue(int block, std::uint64_t rays, MemId where, BlockId produced, Time now,
                                  JobPool& pool, Schedule& s) {
  BlockId qb = produced;
  if (qb == kNone) primary_rays_ += rays;
  else spawned_rays_ += rays;
  if (qb == kNone) {
    qb = new_queue_block(block, rays, pool);
    s.put_initial(qb, where, now, false);
  }
  // Expected children of these rays (Sec. 5.2's alpha/beta model).
  const auto miss = static_cast<std::uint64_t>((1 - opt_.alpha) * static_cast<double>(rays));
  const auto survive = static_cast<std::uint64_t>(opt_.alpha * opt_.beta * static_cast<double>(rays));
  auto it = open_.find({block, where});
  if (it != open_.end() && pool.state(it->second) == JobState::Queued) {
    // Sec. 5.1: merge into the queued job that already holds a queue for this block here.
    const JobId j = it->second;
    pool.add_input(j, qb);
    pool.job(j).work += rays;
    for (BlockId o : pool.job(j).outputs) {
      DataBlock& ob = pool.block(o);
      const bool same = ob.scene_block == scene_[static_cast<std::size_t>(block)];
      ob.bytes += (same ? survive : miss) * opt_.ray_bytes;
    }
    ++merges_;
    return;
  }
  Job job;
  job.name = "ri" + std::to_string(pool.job_count());
  job.type = type_;
  job.inputs = {scene_[static_cast<std::size_t>(block)], qb};
  job.created = now;
  job.work = rays;
  if (static_cast<double>(miss) >= opt_.min_rays) {
    const int next = (block + 1 + static_cast<int>(uniform() * 2) * (opt_.blocks - 2)) % opt_.blocks;  // b+1 or b-1
    job.outputs.push_back(new_queue_block(next, miss, pool));
  }
  if (static_cast<double>(survive) >= opt_.min_rays) job.outputs.push_back(new_queue_block(block, survive, pool));
  const JobId j = pool.add_job(std::move(job));
  open_[{block, where}] = j;
}

void RayStreamWorkload::top_up(Time now, JobPool& pool, Schedule& s) {
  if (now >= opt_.stop_new_batches) {
    stopped_ = true;
    return;
  }
  double zipf_total = 0;
  for (int b = 0; b < opt_.blocks; ++b) zipf_total += 1.0 / (b + 1);
  // Batches that merge into queued jobs add work but not jobs: bound the attempts, so a
  // scene with few blocks (few distinct queues) cannot spin here.
  for (int attempt = 0; attempt < 4 * opt_.backlog && pool.queued_count() < static_cast<std::size_t>(opt_.backlog);
       ++attempt) {
    // Rays concentrate on visible blocks: Zipf popularity.
    double u = uniform() * zipf_total;
    int b = 0;
    while (b + 1 < opt_.blocks && (u -= 1.0 / (b + 1)) > 0) ++b;
    const auto rays = static_cast<std::uint64_t>(opt_.rays_min + (opt_.rays_max - opt_.rays_min) * uniform());
    std::size_t h = static_cast<std::size_t>(uniform() * static_cast<double>(hosts_.size())) % hosts_.size();
    // (After a fault: the next host memory still alive, in order.)
    for (std::size_t k = 0; k < hosts_.size() && !s.memory_alive(hosts_[h]); ++k) h = (h + 1) % hosts_.size();
    if (!s.memory_alive(hosts_[h])) return;
    add_queue(b, rays, hosts_[h], kNone, now, pool, s);
  }
}

void RayStreamWorkload::on_lost(Time now, const std::vector<JobId>& jobs, const std::vector<BlockId>&, JobPool& pool,
                                Schedule& s) {
  for (JobId j : jobs) {
    if (pool.job(j).type == type_) rays_lost_ += pool.job(j).work;
    std::erase_if(open_, [j](const auto& e) { return e.second == j; });
  }
  top_up(now, pool, s);
}

void RayStreamWorkload::on_job_finished(JobId j, Time now, JobPool& pool, Schedule& s) {
  const Job& job = pool.job(j);
  if (job.type != type_) return;
  rays_traced_ += job.work;
  const Activity& a = s.activity(pool.activity(j));
  const MemId where = g_.computes[a.device].memory;
  const std::vector<BlockId> outs = job.outputs;
  for (BlockId o : outs) {
    const DataBlock& ob = pool.block(o);
    const int block = static_cast<int>(std::find(scene_.begin(), scene_.end(), ob.scene_block) - scene_.begin());
    add_queue(block, ob.bytes / opt_.ray_bytes, where, o, now, pool, s);
  }
  top_up(now, pool, s);
}

}  // namespace rayline
