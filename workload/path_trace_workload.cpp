#include "workload/path_trace_workload.hpp"

#include <algorithm>
#include <stdexcept>

#include "common/error.hpp"

namespace rayline {

namespace {
// A frame's report at `now` (delivered, or abandoned); exact is set by the caller.
FrameReport report_of(const FrameState& f, Time now) {
  FrameReport r;
  r.client = f.client;
  r.index = f.index;
  r.requested = f.requested;
  r.delivered = now;
  return r;
}
}  // namespace

PathTraceWorkload::PathTraceWorkload(const DeviceGraph& g, const SceneProfile& profile, PathTraceOptions opt)
    : g_(g), p_(profile), opt_(std::move(opt)), model_(profile, opt_.fidelity, opt_.seed) {
  for (int k = 0; k < kPtJobCount; ++k) {
    type_[static_cast<std::size_t>(k)] = g.job_type(kPtJobTypeNames[static_cast<std::size_t>(k)]);
    if (type_[static_cast<std::size_t>(k)] == kNone)
      throw InputError(g.source_file, "job_types",
                       "the path-tracing workload needs job type '" + std::string(kPtJobTypeNames[static_cast<std::size_t>(k)]) + "'");
  }
  if (opt_.clients < 1 || opt_.clients > kMaxPtClients)
    throw InputError("--clients", "", "must be in [1, " + std::to_string(kMaxPtClients) + "]");
  if (opt_.prediction_depth < 0 || opt_.prediction_depth > 16) throw InputError("--prediction-depth", "", "must be in [0, 16]");
  if (opt_.fidelity == Fidelity::Replay && !opt_.replay)
    throw InputError("--replay", "", "replay fidelity needs a replay log (--replay FILE)");
  if (opt_.client_memory == kNone) opt_.client_memory = g.client_memory;  // the platform's "clients"
  if (opt_.client_memory == kNone)
    for (std::size_t m = 0; m < g.memories.size() && opt_.client_memory == kNone; ++m)
      if (g.memories[m].kind == MemoryKind::Host) opt_.client_memory = static_cast<MemId>(m);
  if (opt_.client_memory == kNone) throw InputError(g.source_file, "memory", "the path-tracing workload needs a host memory");
  bool disk = false;
  for (const MemoryDevice& m : g.memories) disk = disk || m.kind == MemoryKind::Disk;
  if (!disk) throw InputError(g.source_file, "memory", "the path-tracing workload needs a disk (scene blocks start there)");
  Bytes largest = 0;
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    const Bytes cap = g.memories[g.computes[d].memory].capacity;
    largest = std::max(largest, cap);
    for (std::size_t k = 0; k < kPtJobCount; ++k)
      if (g.timing.supports(static_cast<DeviceId>(d), type_[k])) room_[k] = std::max(room_[k], cap);
  }
  for (std::size_t b = 0; b < p_.blocks.size(); ++b)
    if (p_.blocks[b].bytes > largest)
      throw InputError(p_.file, "blocks[" + std::to_string(b) + "].bytes",
                       "larger than every memory device a compute device can use in " + g.source_file);
  open_.assign(queue_slot(kPtJobCount, -1, 0), kNone);
  planned_at_.assign(open_.size(), kNone);
  model_.set_replay(opt_.replay);
  model_.record_to(opt_.record);
  if (opt_.prediction_depth > 0) {
    predictor_ = std::make_unique<JobPredictor>(
        p_, opt_.prediction_depth,
        [this](PtJob kind, int block, BlockId queue, double rays) {
          return make_job(kind, block, queue, pt_traces_rays(kind) ? static_cast<std::uint64_t>(rays) : 0, now_);
        },
        [this](PtJob kind, int block, double rays) {
          return new_queue(kind, block, std::max<Bytes>(1, static_cast<Bytes>(rays * static_cast<double>(bytes_per(kind)))),
                           true, *pool_);
        });
  }
}

double RaySpan::within(Time from, Time to) const {
  if (end <= start) return end >= from && end < to ? static_cast<double>(rays) : 0.0;
  const Time overlap = std::min(end, to) - std::max(start, from);
  return overlap > 0 ? static_cast<double>(rays) * overlap / (end - start) : 0.0;
}

PathTraceWorkload::JobInfo& PathTraceWorkload::info(JobId j) {
  if (static_cast<std::size_t>(j) >= info_.size()) info_.resize(static_cast<std::size_t>(j) + 1);
  return info_[static_cast<std::size_t>(j)];
}

Bytes PathTraceWorkload::bytes_per(PtJob k) const { return pt_record_bytes(p_, k); }

// A queue block: real (consumed by the job that reads it, moved between memories) or the
// placeholder output a parent declares for a predicted child (plain data: evictable once
// no queued job wants it; its size is fixed once committed).
BlockId PathTraceWorkload::new_queue(PtJob kind, int block, Bytes bytes, bool placeholder, JobPool& pool) {
  DataBlock q;
  q.name = (placeholder ? "pred" : "q") + std::to_string(pool.block_count());
  q.kind = pt_queue_kind(kind);
  q.bytes = bytes;
  q.consumed = !placeholder;
  q.movable = kind != PtJob::Accumulate;  // sample records stay where they were made
  if (block >= 0 && kind != PtJob::Accumulate) q.scene_block = scene_[static_cast<std::size_t>(block)];
  return pool.add_block(q);
}

// Sec. 5.1 merges every queue of a kind and block arriving on a memory device into one
// job. Unbounded, that job outgrows every memory device once enough clients feed it (the
// museum with 512 clients asked for 86 GB in one job) and the run stalls. So a job takes
// merged queues only up to the largest memory device that can run its kind, less its
// scene block; the next queue opens a new job. Runs that never reach it are unchanged.
Bytes PathTraceWorkload::merge_cap(PtJob kind, int block) const {
  const Bytes room = room_[static_cast<std::size_t>(kind)];
  const Bytes scene = (kind == PtJob::Intersect || kind == PtJob::Shadow) && block >= 0
                          ? p_.blocks[static_cast<std::size_t>(block)].bytes
                          : 0;
  return room > scene ? room - scene : 0;
}

std::uint64_t PathTraceWorkload::capped_rays(PtJob kind) const {
  if (kind != PtJob::Intersect && kind != PtJob::Shadow && kind != PtJob::Shade) return ~std::uint64_t{0};
  const JobTypeId t = type_[static_cast<std::size_t>(kind)];
  const Bytes cap = t >= 0 && static_cast<std::size_t>(t) < opt_.job_bytes_cap.size() ? opt_.job_bytes_cap[static_cast<std::size_t>(t)] : 0;
  return cap > 0 ? std::max<std::uint64_t>(1, cap / std::max<Bytes>(1, bytes_per(kind))) : ~std::uint64_t{0};
}

Job PathTraceWorkload::make_job(PtJob kind, int block, BlockId queue, std::uint64_t work, Time now) const {
  Job j;
  j.name = std::string(kPtJobTypeNames[static_cast<std::size_t>(kind)]) + (block >= 0 ? "@" + std::to_string(block) : "");
  j.type = type_[static_cast<std::size_t>(kind)];
  if (kind == PtJob::Intersect || kind == PtJob::Shadow) j.inputs.push_back(scene_[static_cast<std::size_t>(block)]);
  j.inputs.push_back(queue);
  j.created = now;
  j.work = work;
  return j;
}

void PathTraceWorkload::start(Time now, JobPool& pool, Schedule& s) {
  now_ = now;
  pool_ = &pool;
  for (std::size_t b = 0; b < p_.blocks.size(); ++b) {
    DataBlock d;
    d.name = "scene" + std::to_string(b);
    d.kind = DataKind::SceneData;
    d.bytes = p_.blocks[b].bytes;
    const BlockId id = pool.add_block(d);
    scene_.push_back(id);
    for (std::size_t m = 0; m < g_.memories.size(); ++m)
      if (g_.memories[m].kind == MemoryKind::Disk) s.put_initial(id, static_cast<MemId>(m), now, true);  // Sec. 6.1
  }
  clients_.resize(static_cast<std::size_t>(opt_.clients));
  for (std::size_t c = 0; c < clients_.size(); ++c) {
    DataBlock fb;
    fb.name = "framebuffer.client" + std::to_string(c);
    fb.kind = DataKind::Framebuffer;
    fb.bytes = static_cast<Bytes>(p_.width) * static_cast<Bytes>(p_.height) * p_.framebuffer_bytes_per_pixel;
    fb.movable = false;
    clients_[c].memory = opt_.client_memory;
    clients_[c].framebuffer = pool.add_block(fb);
    s.put_initial(clients_[c].framebuffer, opt_.client_memory, now, true);
    for (int k = 0; k < std::max(1, opt_.frames_in_flight); ++k)
      if (opt_.frames_per_client == 0 || clients_[c].next_index < opt_.frames_per_client)
        request_frame(static_cast<int>(c), now);
  }
  if (opt_.warm) rayline::warm_start(s, pool, scene_, expected_block_visits(p_), opt_.warm_start);
  top_up(now, pool, s);
}

Bytes PathTraceWorkload::client_framebuffer_bytes() const {
  return static_cast<Bytes>(opt_.clients) * static_cast<Bytes>(p_.width) * static_cast<Bytes>(p_.height) *
         p_.framebuffer_bytes_per_pixel;
}

void PathTraceWorkload::request_frame(int c, Time now, int index) {
  ClientState& cl = clients_[static_cast<std::size_t>(c)];
  FrameState f;
  f.client = c;
  f.index = index >= 0 ? index : cl.next_index++;
  f.keyframe = static_cast<int>((static_cast<std::size_t>(c) + static_cast<std::size_t>(f.index)) % p_.camera_path.size());
  f.units_total = static_cast<std::uint64_t>(p_.spp) * static_cast<std::uint64_t>(p_.tiles());
  f.requested = now;
  cl.frames.push_back(static_cast<std::int64_t>(frames_.size()));
  frames_.push_back(std::move(f));
}

void PathTraceWorkload::top_up(Time now, JobPool& pool, Schedule& s) {
  for (ClientState& cl : clients_)
    for (const std::int64_t fid : cl.frames) {
      const auto uid = static_cast<std::uint32_t>(fid);
      FrameState& f = frames_[uid];
      while (f.next_unit < f.units_total && (f.alive == 0 || f.alive + p_.wave_rays <= p_.inflight_rays)) {
        RayCounts wave = next_wave(p_, uid, f, per_tile());
        f.alive += total(wave);
        if (ray_origin_) split_wave(uid, wave, now, pool, s);
        else add_generate(uid, std::move(wave), kNone, now, pool, s);
      }
    }
}

JobId PathTraceWorkload::add_generate(std::uint32_t uid, RayCounts rays, NodeId hint, Time now, JobPool& pool, Schedule& s) {
  FrameState& f = frames_[uid];
  const MemId client_memory = clients_[static_cast<std::size_t>(f.client)].memory;
  ++f.generate_pending;
  DataBlock req;
  req.name = "request" + std::to_string(pool.block_count());
  req.kind = DataKind::Generic;
  req.bytes = p_.request_bytes;
  req.consumed = true;
  const BlockId rb = pool.add_block(req);
  s.put_initial(rb, client_memory, now, false);
  Job job = make_job(PtJob::Generate, -1, rb, 0, now);
  job.node_hint = hint;
  std::uint64_t wave = 0;
  for (const auto& [key, n] : rays) wave += n;
  job.expected_output_bytes = static_cast<Bytes>(wave) * bytes_per(PtJob::Intersect);  // its camera rays
  const JobId j = pool.add_job(std::move(job));
  JobInfo& I = info(j);
  I.kind = PtJob::Generate;
  I.mem = client_memory;
  I.rays = std::move(rays);
  I.frame = uid;
  ++jobs_by_kind_[static_cast<int>(PtJob::Generate)];
  return j;
}

// Rule 8 (set_ray_origin): the wave's entry split drawn now, one job per node named.
void PathTraceWorkload::split_wave(std::uint32_t uid, const RayCounts& wave, Time now, JobPool& pool, Schedule& s) {
  const FrameState& f = frames_[uid];
  const std::uint64_t number = waves_++;
  std::map<NodeId, EntryPart> parts;  // by node: the jobs in node order
  RayCounts background;
  std::vector<std::uint64_t>& out = scratch_;
  for (const auto& [key, n] : wave) {
    model_.split(context(RayStage::Entry, key, f.keyframe), n, out);
    if (out[0]) background.emplace_back(key, out[0]);
    for (std::size_t b = 1; b < out.size(); ++b)
      if (out[b]) parts[ray_origin_(number, scene_[b - 1])].entry.emplace_back(static_cast<int>(b - 1), key, out[b]);
  }
  if (parts.empty()) parts[kNone];  // every ray misses the scene: one job for the background
  parts.begin()->second.background = std::move(background);
  for (auto& [node, part] : parts) {
    RayCounts rays = part.background;
    for (const auto& [b, key, n] : part.entry) add_count(rays, key, n);
    normalize(rays);
    const JobId j = add_generate(uid, std::move(rays), node, now, pool, s);
    entry_parts_.emplace(j, std::move(part));
  }
}

// A queue of `kind` for `block` now sits on `mem`: merge it into the queued job holding one
// there (Sec. 5.1), or make a new job (with its predicted subtree, Sec. 5.2).
void PathTraceWorkload::add_queue(PtJob kind, int block, MemId mem, RayCounts rays, RayCounts records, Time now,
                                  JobPool& pool, Schedule& s) {
  const std::uint64_t n = kind == PtJob::Accumulate ? total(records) : total(rays);
  if (n == 0) return;
  // A device-sized cap (job_cap): a queue larger than it is split, in key order, into
  // queues of at most the cap, each joining or making a job as below.
  if (const std::uint64_t most = capped_rays(kind); n > most && records.empty()) {
    RayCounts part;
    std::uint64_t room = most;
    for (auto [k, c] : rays)
      while (c > 0) {
        const std::uint64_t take = std::min(c, room);
        part.emplace_back(k, take);
        c -= take, room -= take;
        if (room == 0) {
          add_queue(kind, block, mem, std::move(part), {}, now, pool, s);
          part.clear();
          room = most;
        }
      }
    if (!part.empty()) add_queue(kind, block, mem, std::move(part), {}, now, pool, s);
    return;
  }
  const std::size_t key = queue_slot(static_cast<int>(kind), block, mem);
  // Sec. 5.1: rays arriving where a planned job will process a queue of the same kind and
  // block, before it started, join that queue (its E-job then runs for the merged size,
  // exec_scale). Their bytes are not added to the memory device's reservation: the
  // Schedule has no API to grow a committed copy. So, as for queued jobs, a planned job
  // takes them only while its queue stays within merge_cap (else it would grow without
  // bound, unaccounted, while it waits to start); past that they open a new job.
  const auto held = [&](JobId j) { return kind == PtJob::Accumulate ? total(info(j).records) : total(info(j).rays); };
  const auto fits = [&](JobId j) {
    return held(j) + n <= std::min(merge_cap(kind, block) / std::max<Bytes>(1, bytes_per(kind)), capped_rays(kind));
  };
  scan_planned(s, pool);
  if (opt_.merge_planned && planned_at_[key] != kNone) {
    const JobId j = planned_at_[key];
    JobInfo& I = info(j);
    const Activity* pa = pool.state(j) == JobState::Planned ? &s.activity(pool.activity(j)) : nullptr;
    if (pa && pa->state == ActivityState::Planned && !pa->cancelled && I.resolved && fits(j)) {
      merge_into(I.rays, rays);
      merge_into(I.records, records);
      if (pt_traces_rays(kind)) pool.job(j).work += n;
      ++merges_;
      ++merges_planned_;
      // The plan learns the longer E-job at once (else it stays wrong until it runs).
      if (opt_.retime_merged) s.retime(pool.activity(j), exec_time_now(j, pa->device));
      return;
    }
  }
  const BlockId qb = new_queue(kind, block, n * bytes_per(kind), false, pool);
  s.put_initial(qb, mem, now, false);
  if (const JobId j = open_[key]; j != kNone && pool.state(j) == JobState::Queued && fits(j)) {
    JobInfo& I = info(j);
    const std::uint64_t before = held(j);
    pool.add_input(j, qb);
    merge_into(I.rays, rays);
    merge_into(I.records, records);
    if (pt_traces_rays(kind)) pool.job(j).work += n;
    if (predictor_ && before > 0) predictor_->rescale(j, static_cast<double>(before + n) / static_cast<double>(before), pool);
    ++merges_;
    return;
  }
  Job job = make_job(kind, block, qb, pt_traces_rays(kind) ? n : 0, now);
  const JobId first = static_cast<JobId>(pool.job_count());
  const bool predict = predictor_ && (kind == PtJob::Intersect || kind == PtJob::Shade);
  const JobId j = predict ? predictor_->add(std::move(job), kind, block, static_cast<double>(n), pool) : pool.add_job(std::move(job));
  JobInfo& I = info(j);
  I.kind = kind;
  I.block = block;
  I.mem = mem;
  I.rays = std::move(rays);
  I.records = std::move(records);
  open_[key] = j;
  ++jobs_by_kind_[static_cast<int>(kind)];
  for (JobId c = first; c < static_cast<JobId>(pool.job_count()); ++c) {
    if (c == j) continue;
    JobInfo& C = info(c);  // a predicted job added with j
    C.kind = predictor_->kind(c);
    C.block = predictor_->block(c);
    C.resolved = false;
  }
}

// Real rays of `parent` for (kind, block) on `mem`: given to the planned predicted child
// that expected them, else queued (merged or new).
void PathTraceWorkload::route(JobId parent, Dest& d, MemId mem, Time now, JobPool& pool, Schedule& s) {
  normalize(d.rays);
  const std::uint64_t n = total(d.rays);
  if (predictor_) {
    const JobId c = predictor_->resolve(parent, d.kind, d.block, n, pool);
    if (c != kNone) {
      JobInfo& C = info(c);
      merge_into(C.rays, d.rays);
      C.resolved = true;
      pool.job(c).work = pt_traces_rays(d.kind) ? total(C.rays) : 0;
      // Planned for the predicted queue; it will run for the real one (Sec. 5.2).
      if (opt_.retime_merged && pool.state(c) == JobState::Planned)
        s.retime(pool.activity(c), exec_time_now(c, s.activity(pool.activity(c)).device));
      return;
    }
  }
  add_queue(d.kind, d.block, mem, std::move(d.rays), {}, now, pool, s);
}

SplitContext PathTraceWorkload::context(RayStage stage, std::uint64_t key, int block) const {
  const FrameState& f = frames_[key_frame(key)];
  SplitContext c;
  c.stage = stage;
  c.client = f.client;
  c.frame = f.index;
  c.tile = key_tile(key);
  c.bounce = key_bounce(key);
  c.block = block;
  return c;
}

void PathTraceWorkload::sample_records(RayCounts& recs, RayCounts& samples, std::uint32_t frame, int tile,
                                       std::uint64_t completed, std::uint64_t contributions) {
  const std::uint64_t r = completed + contributions;
  if (r == 0) return;
  add_count(recs, ray_key(frame, 0, 0), r);
  add_count(samples, ray_key(frame, tile, 0), completed);
  frames_[frame].records_pending += r;
}

void PathTraceWorkload::on_job_finished(JobId j, Time now, JobPool& pool, Schedule& s) {
  now_ = now;
  pool_ = &pool;
  if (static_cast<std::size_t>(j) >= info_.size()) return;
  // Moved out (info_ grows below, and a finished job's counts are not needed again): the
  // slot keeps what scan_planned/exec_scale read, and the total for job_rays().
  const JobInfo I = std::move(info_[static_cast<std::size_t>(j)]);
  {
    JobInfo& F = info_[static_cast<std::size_t>(j)];
    F = JobInfo{};
    F.kind = I.kind;
    F.block = I.block;
    F.mem = I.mem;
    F.frame = I.frame;
    F.resolved = I.resolved;
    F.finished = true;
    F.processed = I.kind == PtJob::Accumulate ? total(I.records) : total(I.rays);
  }
  const Activity& act = s.activity(pool.activity(j));
  const MemId mem = g_.computes[act.device].memory;
  const Time started = std::min(act.start, now);
  // The rays going to (kind, block), routed below in (kind, block) order. Every key of the
  // job sends to the same few destinations, so each caller slot looks its destination up
  // once, at first use (exactly the destinations used are made). There are at most as many
  // as blocks, plus two, so the reserved list never moves them.
  std::vector<Dest>& dests = dests_;
  dests.clear();
  dests.reserve(p_.blocks.size() + 2);
  std::vector<RayCounts*>& to = dest_cache_;
  to.assign(to.size(), nullptr);
  auto dest = [&](std::size_t slot, PtJob k, int b) -> RayCounts& {
    if (slot >= to.size()) to.resize(slot + 1, nullptr);
    if (!to[slot]) {
      auto it = std::find_if(dests.begin(), dests.end(), [&](const Dest& d) { return d.kind == k && d.block == b; });
      if (it == dests.end()) {
        if (dests.size() == dests.capacity()) throw std::logic_error("more destinations than blocks");
        it = dests.insert(dests.end(), Dest{k, b, {}});
      }
      to[slot] = &it->rays;
    }
    return *to[slot];
  };
  RayCounts recs, samples;
  std::uint64_t ended = 0, created = 0;
  std::vector<std::uint64_t>& out = scratch_;
  switch (I.kind) {
    case PtJob::Generate: {
      FrameState& f = frames_[I.frame];
      --f.generate_pending;
      if (auto it = entry_parts_.find(j); it != entry_parts_.end()) {  // split when requested (rule 8)
        for (const auto& [key, n] : it->second.background) {
          tally_.primary += n;
          created += n;
          tally_.escaped += n;
          ended += n;
          f.alive -= n;
          sample_records(recs, samples, I.frame, key_tile(key), n, n);
        }
        for (const auto& [b, key, n] : it->second.entry) {
          tally_.primary += n;
          created += n;
          add_count(dest(static_cast<std::size_t>(b) + 1, PtJob::Intersect, b), key, n);
        }
        entry_parts_.erase(it);
        break;
      }
      for (const auto& [key, n] : I.rays) {
        model_.split(context(RayStage::Entry, key, f.keyframe), n, out);
        tally_.primary += n;
        created += n;
        tally_.escaped += out[0];  // missed every cell: background
        ended += out[0];
        f.alive -= out[0];
        sample_records(recs, samples, I.frame, key_tile(key), out[0], out[0]);
        for (std::size_t b = 1; b < out.size(); ++b) add_count(dest(b, PtJob::Intersect, static_cast<int>(b - 1)), key, out[b]);
      }
      break;
    }
    case PtJob::Intersect: {
      const ProfileBlock& blk = p_.blocks[static_cast<std::size_t>(I.block)];
      std::uint64_t rays = 0, hits = 0;
      for (const auto& [key, n] : I.rays) {
        model_.split(context(RayStage::Intersect, key, I.block), n, out);
        rays += n;
        hits += out[kHit];
        tally_.hit += out[kHit];
        tally_.escaped += out[kEscape];
        ended += out[kHit] + out[kEscape];
        frames_[key_frame(key)].alive -= out[kEscape];  // hits stay alive as hit records
        sample_records(recs, samples, key_frame(key), key_tile(key), out[kEscape], out[kEscape]);
        add_count(dest(0, PtJob::Shade, I.block), key, out[kHit]);
        for (std::size_t i = 0; i < blk.neighbours.size(); ++i)
          add_count(dest(1 + i, PtJob::Intersect, blk.neighbours[i].block), key, out[kFirstNeighbour + i]);
      }
      if (rays) traced_.push_back({started, now, rays});
      if (predictor_) predictor_->observe_intersect(I.block, rays, hits);
      break;
    }
    case PtJob::Shade: {
      std::uint64_t hits = 0, survived = 0;
      for (const auto& [key, n] : I.rays) {
        model_.split(context(RayStage::Shade, key, I.block), n, out);
        hits += n;
        survived += out[kSurvive];
        tally_.shadow += n;  // next-event estimation: one shadow ray per hit
        tally_.secondary += out[kSurvive];
        created += n + out[kSurvive];
        FrameState& f = frames_[key_frame(key)];
        f.alive += out[kSurvive];  // n hit records become n shadow rays, plus the survivors
        sample_records(recs, samples, key_frame(key), key_tile(key), out[kTerminate], 0);
        add_count(dest(0, PtJob::Shadow, I.block), key, n);
        if (out[kSurvive]) add_count(dest(1, PtJob::Intersect, I.block), key + 1, out[kSurvive]);  // bounce + 1
      }
      if (predictor_) predictor_->observe_shade(I.block, hits, survived);
      break;
    }
    case PtJob::Shadow: {
      const ProfileBlock& blk = p_.blocks[static_cast<std::size_t>(I.block)];
      std::uint64_t rays = 0;
      for (const auto& [key, n] : I.rays) {
        model_.split(context(RayStage::Shadow, key, I.block), n, out);
        rays += n;
        tally_.occluded += out[kOccluded];
        tally_.lit += out[kLit];
        ended += out[kOccluded] + out[kLit];
        frames_[key_frame(key)].alive -= out[kOccluded] + out[kLit];
        sample_records(recs, samples, key_frame(key), key_tile(key), 0, out[kLit]);
        for (std::size_t i = 0; i < blk.neighbours.size(); ++i)
          add_count(dest(i, PtJob::Shadow, blk.neighbours[i].block), key, out[kFirstNeighbour + i]);
      }
      if (rays) traced_.push_back({started, now, rays});
      break;
    }
    case PtJob::Accumulate: {
      for (const auto& [key, n] : I.rays) {
        auto& tiles = frames_[key_frame(key)].partial[mem];
        tiles.resize(static_cast<std::size_t>(p_.tiles()), 0);
        tiles[static_cast<std::size_t>(key_tile(key))] += n;
      }
      for (const auto& [key, r] : I.records) frames_[key_frame(key)].records_pending -= r;
      break;
    }
    case PtJob::Compose: {
      FrameState& f = frames_[I.frame];
      f.delivered = true;
      f.delivered_at = now;
      f.delivered_samples.assign(static_cast<std::size_t>(p_.tiles()), 0);
      for (const auto& [m, tiles] : f.partial)
        for (std::size_t t = 0; t < tiles.size(); ++t) f.delivered_samples[t] += tiles[t];
      FrameReport r = report_of(f, now);
      r.exact = true;
      if (per_tile()) {
        for (int t = 0; t < p_.tiles(); ++t)
          r.exact = r.exact && f.delivered_samples[static_cast<std::size_t>(t)] ==
                                   static_cast<std::uint64_t>(p_.spp) * p_.tile_pixels(t);
      } else {  // counts carry no tile (path_trace_clients.hpp): the frame's total
        std::uint64_t got = 0, want = 0;
        for (int t = 0; t < p_.tiles(); ++t) {
          got += f.delivered_samples[static_cast<std::size_t>(t)];
          want += static_cast<std::uint64_t>(p_.spp) * p_.tile_pixels(t);
        }
        r.exact = got == want;
      }
      reports_.push_back(r);
      ClientState& cl = clients_[static_cast<std::size_t>(f.client)];
      ++cl.frames_done;
      std::erase(cl.frames, static_cast<std::int64_t>(I.frame));
      if ((opt_.frames_per_client == 0 || cl.next_index < opt_.frames_per_client) && now < opt_.stop_new_frames)
        request_frame(f.client, now);
      break;
    }
  }
  if (ended) ended_.push_back({started, now, ended});
  if (created) created_.push_back({started, now, created});
  std::sort(dests.begin(), dests.end(), [](const Dest& a, const Dest& b) {
    return std::pair(static_cast<int>(a.kind), a.block) < std::pair(static_cast<int>(b.kind), b.block);
  });
  for (Dest& d : dests) route(j, d, mem, now, pool, s);
  if (predictor_) {  // children it produced nothing for: failed (Sec. 5.2)
    predictor_->finish(j, pool);
    // Planned failures (deepest first): nothing to process; withdrawn with their T-jobs.
    for (JobId c : predictor_->take_failed_planned()) {
      JobInfo& C = info(c);
      C.resolved = true;
      C.rays.clear();
      pool.job(c).work = 0;
      if (!opt_.cancel_failed) continue;
      const Schedule::CancelCount n = s.cancel_job(c);
      withdrawn_.execs += n.execs;
      withdrawn_.transfers += n.transfers;
      withdrawn_.kept_transfers += n.kept_transfers;
      withdrawn_.bytes += n.bytes;
    }
  }
  normalize(samples);
  if (!recs.empty()) add_queue(PtJob::Accumulate, -1, mem, std::move(samples), std::move(recs), now, pool, s);
  check_frames(now, pool, s);
  top_up(now, pool, s);
}

// Where each newly committed ray job will run (merge targets while it has not started).
void PathTraceWorkload::scan_planned(const Schedule& s, const JobPool& pool) {
  for (; act_cursor_ < s.activity_count(); ++act_cursor_) {
    const Activity& a = s.activity(static_cast<ActivityId>(act_cursor_));
    if (a.kind != ActivityKind::Exec || a.job < 0 || static_cast<std::size_t>(a.job) >= info_.size()) continue;
    const JobInfo& I = info_[static_cast<std::size_t>(a.job)];
    if (I.kind == PtJob::Generate || I.kind == PtJob::Compose) continue;
    (void)pool;
    planned_at_[queue_slot(static_cast<int>(I.kind), I.block, g_.computes[a.device].memory)] = a.job;
  }
}

// A frame whose rays and sample records are all done is composed at its client (Sec. 5.1:
// framebuffers move only for AdditiveCompose).
void PathTraceWorkload::check_frames(Time now, JobPool& pool, Schedule& s) {
  for (ClientState& cl : clients_)
    for (const std::int64_t fid : cl.frames) {
      const auto uid = static_cast<std::uint32_t>(fid);
      FrameState& f = frames_[uid];
      if (f.composing || f.next_unit < f.units_total || f.generate_pending > 0 || f.alive > 0 || f.records_pending > 0)
        continue;
      f.composing = true;
      Job job;
      job.name = "AdditiveCompose.frame" + std::to_string(uid);
      job.type = type_[static_cast<int>(PtJob::Compose)];
      job.created = now;
      for (const auto& [m, tiles] : f.partial) {
        Bytes px = 0;
        if (per_tile()) {
          for (std::size_t t = 0; t < tiles.size(); ++t)
            if (tiles[t]) px += p_.tile_pixels(static_cast<int>(t));
        } else {  // all under tile 0: the expected coverage of its samples, in mean tiles
          std::uint64_t n = 0;
          for (std::uint64_t x : tiles) n += x;
          const Bytes frame_px = static_cast<Bytes>(p_.width) * static_cast<Bytes>(p_.height);
          px = frame_px * partial_tiles(n, p_.tiles()) / static_cast<Bytes>(std::max(1, p_.tiles()));
        }
        DataBlock fb;
        fb.name = "partial" + std::to_string(pool.block_count());
        fb.kind = DataKind::Framebuffer;
        fb.bytes = std::max<Bytes>(1, px * p_.framebuffer_bytes_per_pixel);
        fb.consumed = true;
        const BlockId b = pool.add_block(fb);
        s.put_initial(b, m, now, false);
        job.inputs.push_back(b);
      }
      job.inputs.push_back(cl.framebuffer);
      const JobId j = pool.add_job(std::move(job));
      JobInfo& I = info(j);
      I.kind = PtJob::Compose;
      I.mem = cl.memory;
      I.frame = uid;
      ++jobs_by_kind_[static_cast<int>(PtJob::Compose)];
    }
}

void PathTraceWorkload::on_idle(Time now, JobPool& pool, Schedule& s) {
  check_frames(now, pool, s);
  top_up(now, pool, s);
  if (pool.queued_count() == 0 && !finished())
    for (const ClientState& cl : clients_)
      if (!cl.frames.empty())
        throw std::logic_error("path-trace workload: frame " + std::to_string(cl.frames.front()) + " has " +
                               std::to_string(frames_[static_cast<std::size_t>(cl.frames.front())].alive) +
                               " rays alive but no job left to trace them");
}

void PathTraceWorkload::on_requeued(Time, const std::vector<JobId>& jobs, JobPool&, Schedule&) {
  // No longer planned: rays arriving later must not count on merging into them there.
  for (JobId& p : planned_at_)
    if (p != kNone && std::find(jobs.begin(), jobs.end(), p) != jobs.end()) p = kNone;
}

void PathTraceWorkload::on_lost(Time now, const std::vector<JobId>& jobs, const std::vector<BlockId>& blocks,
                                JobPool& pool, Schedule& s) {
  for (const ClientState& cl : clients_)
    if (!s.memory_alive(cl.memory))
      throw std::runtime_error("the client's memory device " + g_.memories[static_cast<std::size_t>(cl.memory)].name +
                               " was lost (its framebuffer with it): the run cannot go on");
  std::vector<std::uint32_t> hit_frames;
  auto frame_hit = [&](std::uint32_t f) {
    if (std::find(hit_frames.begin(), hit_frames.end(), f) == hit_frames.end()) hit_frames.push_back(f);
  };
  for (JobId j : jobs) {
    if (j < 0 || static_cast<std::size_t>(j) >= info_.size()) continue;
    JobInfo& I = info_[static_cast<std::size_t>(j)];
    std::replace(open_.begin(), open_.end(), j, JobId{kNone});
    std::replace(planned_at_.begin(), planned_at_.end(), j, JobId{kNone});
    switch (I.kind) {
      case PtJob::Generate: {  // the wave's primary rays are never made: they were counted alive
        FrameState& f = frames_[I.frame];
        const std::uint64_t n = total(I.rays);
        entry_parts_.erase(j);
        f.alive -= std::min(f.alive, n);
        --f.generate_pending;
        frame_hit(I.frame);
        break;
      }
      case PtJob::Intersect:
      case PtJob::Shade:  // (hit records: their rays ended already, as hits)
      case PtJob::Shadow:
        for (const auto& [key, n] : I.rays) {
          FrameState& f = frames_[key_frame(key)];
          f.alive -= std::min(f.alive, n);
          if (I.kind != PtJob::Shade) tally_.lost += n;
          frame_hit(key_frame(key));
        }
        break;
      case PtJob::Accumulate:
        for (const auto& [key, n] : I.records) {
          FrameState& f = frames_[key_frame(key)];
          f.records_pending -= std::min(f.records_pending, n);
          frame_hit(key_frame(key));
        }
        break;
      case PtJob::Compose: frame_hit(I.frame); break;
    }
    I.rays.clear();
    I.records.clear();
    I.finished = true;
  }
  (void)blocks;  // (the jobs say what was lost)
  for (std::uint32_t uid : hit_frames) {
    FrameState& f = frames_[uid];
    if (f.abandoned || f.delivered) continue;
    f.abandoned = true;
    f.next_unit = f.units_total;  // no more waves: what is alive drains, nothing is composed
    ClientState& cl = clients_[static_cast<std::size_t>(f.client)];
    FrameReport r = report_of(f, now);
    r.abandoned = true;
    abandoned_.push_back(r);
    if (std::erase(cl.frames, static_cast<std::int64_t>(uid)) > 0)
      request_frame(f.client, now, f.index);  // the same frame again
  }
  check_frames(now, pool, s);
  top_up(now, pool, s);
}

bool PathTraceWorkload::finished() const {
  for (const ClientState& cl : clients_) {
    if (!cl.frames.empty()) return false;
    if (opt_.frames_per_client > 0 && cl.frames_done < opt_.frames_per_client && now_ < opt_.stop_new_frames) return false;
  }
  return opt_.frames_per_client > 0 || now_ >= opt_.stop_new_frames;
}

std::uint64_t PathTraceWorkload::rays_alive() const {
  std::uint64_t a = 0;
  for (const FrameState& f : frames_) a += f.alive;
  return a;
}

std::uint64_t PathTraceWorkload::job_rays(JobId j) const {
  if (j < 0 || static_cast<std::size_t>(j) >= info_.size()) return 0;
  const JobInfo& I = info_[static_cast<std::size_t>(j)];
  if (I.kind == PtJob::Accumulate || I.kind == PtJob::Compose) return 0;
  return I.finished ? I.processed : total(I.rays);
}

// The E-job's duration was computed at commit from the sizes of its inputs then; what it
// processes is its queue now (merges while planned, the real rays of a predicted job).
double PathTraceWorkload::exec_scale(JobId j, DeviceId d, const Activity& planned) const {
  if (j < 0 || static_cast<std::size_t>(j) >= info_.size()) return 1.0;
  const JobInfo& I = info_[static_cast<std::size_t>(j)];
  if (I.kind == PtJob::Generate || I.kind == PtJob::Compose || !I.resolved || I.finished) return 1.0;
  const std::uint64_t n = I.kind == PtJob::Accumulate ? total(I.records) : total(I.rays);
  if (n == 0) return 0.0;
  const Time actual = exec_time_now(j, d);
  return planned.duration > 0 ? actual / planned.duration : 1.0;
}

// Eq. 2 for the queue job j holds now on device d (a finished job: the queue it processed).
Time PathTraceWorkload::exec_time_now(JobId j, DeviceId d) const {
  const JobInfo& I = info_[static_cast<std::size_t>(j)];
  const std::uint64_t n = I.finished ? I.processed : I.kind == PtJob::Accumulate ? total(I.records) : total(I.rays);
  std::vector<InputSize> sizes;
  if (I.kind == PtJob::Intersect || I.kind == PtJob::Shadow)
    sizes.push_back({DataKind::SceneData, pool_->block(scene_[static_cast<std::size_t>(I.block)]).bytes});
  sizes.push_back({pt_queue_kind(I.kind), n * bytes_per(I.kind)});
  return g_.timing.exec_time(d, pool_->job(j).type, sizes);
}

}  // namespace rayline
