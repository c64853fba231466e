#include "sched/policy/rayline/rayline_scheduler.hpp"

#include <algorithm>
#include <chrono>

#include "sched/policy/image_split.hpp"

namespace rayline {

std::optional<unsigned> rayline_rules_off(std::string_view list) {
  unsigned mask = 0;
  while (!list.empty()) {
    const std::size_t comma = list.find(',');
    const std::string_view name = list.substr(0, comma);
    list = comma == std::string_view::npos ? std::string_view{} : list.substr(comma + 1);
    if (name.empty()) continue;
    const unsigned bit = rayline_rule_bit(name);
    if (bit == 0) return std::nullopt;
    mask |= bit;
  }
  return mask;
}

RaylineOptions rayline_options(Time horizon, unsigned off, unsigned on_rules) {
  RaylineOptions o{.horizon = horizon};
  off |= kRaylineRulesOffByDefault & ~on_rules;
  const auto on = [off](std::string_view rule) { return (off & rayline_rule_bit(rule)) == 0; };
  o.ownership = on("ownership");
  o.image_split = on("image-split");
  o.completion_aware = on("completion");
  if (!on("batching")) o.min_remote_bytes = 0;
  o.no_waiting = on("no-waiting");
  o.job_seconds = on("job-size") ? horizon / 4 : 0;
  o.owner_generation = on("generation");
  o.room = on("room");
  if (!on("batching") || !(on("hold") || on("generation"))) o.min_local_bytes = 0;
  return o;
}

std::string RaylineScheduler::describe() const {
  return "rayline{horizon=" + std::to_string(opt_.horizon) + "s; ownership=" + (opt_.ownership ? "1" : "0") +
         "; image_split=" + (opt_.image_split ? "1" : "0") + "; completion_aware=" + (opt_.completion_aware ? "1" : "0") +
         "; min_remote_bytes=" + std::to_string(opt_.min_remote_bytes) + "; hold=" + std::to_string(opt_.hold) +
         "s; no_waiting=" + (opt_.no_waiting ? "1" : "0") + "; slack=" + std::to_string(opt_.slack) +
         "s; job_seconds=" + std::to_string(opt_.job_seconds) +
         "s; owner_generation=" + (places_ray_origins() ? "1" : "0") +
         "; min_local_bytes=" + std::to_string(opt_.min_local_bytes) + "; room=" + (opt_.room ? "1" : "0") + "; groups=" + std::to_string(own_.groups.size()) + "}";
}

// Rule 1's input: the scene blocks, in id order, as they appear in the pool.
void RaylineScheduler::update_scene(const JobPool& pool, const DeviceGraph& g) {
  bool changed = own_.groups.empty();
  if (scene_index_.size() < pool.block_count()) scene_index_.resize(pool.block_count(), -1);
  for (; blocks_seen_ < pool.block_count(); ++blocks_seen_) {
    const auto b = static_cast<BlockId>(blocks_seen_);
    if (pool.block(b).kind != DataKind::SceneData) continue;
    scene_index_[blocks_seen_] = static_cast<std::int32_t>(scene_.size());
    scene_.push_back(b);
    largest_scene_ = std::max(largest_scene_, pool.block(b).bytes);
    changed = true;
  }
  if (!changed) return;
  std::vector<Bytes> bytes;
  for (BlockId b : scene_) bytes.push_back(pool.block(b).bytes);
  own_ = plan_ownership(g, bytes);
  const std::vector<double>& w = own_.weight;
  group_weight_.assign(own_.groups.size(), 0.0);
  node_weight_.assign(own_.groups.size(), {});
  for (std::size_t k = 0; k < own_.groups.size(); ++k)
    for (NodeId n : own_.groups[k]) {
      group_weight_[k] += w[static_cast<std::size_t>(n)];
      node_weight_[k].push_back(w[static_cast<std::size_t>(n)]);
    }
  homes_.assign(homes_.size(), kNone);  // owners moved
  by_node_.clear();
}

NodeId RaylineScheduler::home(JobId j, const JobPool& pool, const Schedule& s) {
  if (homes_.size() < pool.job_count()) homes_.resize(pool.job_count(), kNone);
  if (rays_at_.size() < pool.job_count()) rays_at_.resize(pool.job_count(), kNone);
  NodeId& h = homes_[static_cast<std::size_t>(j)];
  const DeviceGraph& g = s.graph();
  auto runs_it = [&](NodeId n) {  // some live device of n runs j's type
    for (DeviceId d : g.nodes[static_cast<std::size_t>(n)].computes)
      if (s.compute_alive(d) && g.timing.supports(d, pool.job(j).type)) return true;
    return false;
  };
  if (h != kNone) return !s.any_lost() || runs_it(h) ? h : kNone;
  const Job& job = pool.job(j);
  NodeId at = kNone;  // where its rays (or other non-scene inputs) are
  bool generic_only = !job.inputs.empty();
  for (BlockId b : job.inputs) {
    const DataBlock& blk = pool.block(b);
    generic_only = generic_only && blk.kind == DataKind::Generic;
    if (blk.kind == DataKind::SceneData || s.copies(b).empty()) continue;
    const NodeId n = g.memories[s.copies(b).front().mem].node;
    if (!blk.movable) {  // pinned (a client's framebuffer): the job goes to it
      at = n;
      break;
    }
    if (at == kNone) at = n;
  }
  rays_at_[static_cast<std::size_t>(j)] = at;
  NodeId pick = at;
  const InputSummaries::Summary& in = inputs_.of(j, pool);
  if (places_ray_origins() && job.node_hint != kNone) {
    pick = job.node_hint;  // Rule 8: made for the owner of the blocks its rays enter (ray_origin)
  } else if (opt_.image_split && generic_only && g.job_types[static_cast<std::size_t>(job.type)] == "GenerateRays" &&
             !own_.groups.empty()) {
    // Rule 2: an image split, group first, then a node of the group (another hash of the id).
    const int k = weighted_pick(static_cast<std::uint64_t>(j), group_weight_);
    if (k >= 0) {
      const int i = weighted_pick(static_cast<std::uint64_t>(j) ^ 0x6a09e667f3bcc909ull, node_weight_[static_cast<std::size_t>(k)]);
      if (i >= 0) pick = own_.groups[static_cast<std::size_t>(k)][static_cast<std::size_t>(i)];
    }
  } else if (opt_.ownership && in.scene.size() == 1 && at != kNone) {
    // Rule 1: the owner of its block in the group its rays are in.
    const int k = own_.group_of_node[static_cast<std::size_t>(at)];
    const std::int32_t i = scene_index_[static_cast<std::size_t>(in.scene[0])];
    if (k >= 0 && i >= 0) pick = own_.owner[static_cast<std::size_t>(k)][static_cast<std::size_t>(i)];
  }
  if (pick != kNone && !runs_it(pick)) pick = kNone;
  h = pick;
  return h;
}

NodeId RaylineScheduler::ray_origin(std::uint64_t wave, BlockId entry, const JobPool& pool, const Schedule& s) {
  if (!places_ray_origins()) return kNone;
  if (blocks_seen_ < pool.block_count()) update_scene(pool, s.graph());
  const auto e = static_cast<std::size_t>(entry);
  if (own_.groups.empty() || entry < 0 || e >= scene_index_.size() || scene_index_[e] < 0) return kNone;
  // Rule 2's group for the wave (a well-mixed point per wave), then the block's owner there.
  const int k = weighted_pick(wave, group_weight_);
  if (k < 0) return kNone;
  return own_.owner[static_cast<std::size_t>(k)][static_cast<std::size_t>(scene_index_[e])];
}

// A device with nothing unfinished is free now whatever its last projection says (the
// timelines are re-projected only now and then: rule 6).
Time RaylineScheduler::free_at(DeviceId d, Time now, const Schedule& s) {
  return s.unfinished_on_device(d) == 0 ? now : std::max(now, s.device_timeline(d).busy_until);
}

PlanStats RaylineScheduler::plan(Time now, JobPool& pool, Schedule& s) {
  const auto t0 = std::chrono::steady_clock::now();
  PlanStats st;
  auto done = [&] {
    st.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return st;
  };
  if (bound_ != &s || !placer_) {
    placer_ = std::make_unique<Placer>(s);
    fetch_bound_ = std::make_unique<FetchBound>(s.graph());
    bound_ = &s;
    own_ = {};
    scene_.clear();
    largest_scene_ = 0;
    scene_index_.clear();
    blocks_seen_ = 0;
    inputs_.clear();
    homes_.clear();
    rays_at_.clear();
    by_node_.clear();
    fresh_.clear();
    recheck_.clear();
    planned_at_.clear();
    seen_epoch_.clear();
    wake_at_.clear();
    stale_.clear();
    left_seen_ = pool.left_queue().size();
    merged_into_.clear();
    merged_seen_ = 0;
    reprojected_ = -kNever;
    long_wait_job_.clear();
  }
  s.set_eviction_policy(Schedule::EvictionPolicy::QueueAware);
  if (pool.queued_count() == 0) return done();
  const DeviceGraph& g = s.graph();
  // Rule 6: a node is planned once one of its live devices has less than half the horizon.
  auto wants_work = [&](std::size_t n) {
    for (DeviceId d : g.nodes[n].computes)
      if (s.compute_alive(d) && free_at(d, now, s) < now + 0.5 * opt_.horizon) return true;
    return false;
  };
  auto idle = [&](std::size_t n) {  // a live device free now
    for (DeviceId d : g.nodes[n].computes)
      if (s.compute_alive(d) && free_at(d, now, s) <= now) return true;
    return false;
  };
  bool any = false;
  for (std::size_t n = 0; n < g.nodes.size() && !any; ++n) any = wants_work(n);
  if (!any) return done();
  update_scene(pool, g);
  // Queued jobs by home node, kept across calls (as Budge's buckets: new jobs join, stale
  // entries drop out while scanned); all again after a lost device (homes can change).
  if (by_node_.size() != g.nodes.size() + 1 || s.any_lost()) {
    by_node_.assign(g.nodes.size() + 1, {});
    bucketed_ = 0;
  }
  if (fresh_.size() != g.nodes.size() + 1) fresh_.assign(g.nodes.size() + 1, true);
  if (recheck_.size() != g.nodes.size()) recheck_.assign(g.nodes.size(), -kNever);
  if (planned_at_.size() != g.nodes.size()) planned_at_.assign(g.nodes.size(), -kNever);
  if (held_until_.size() != g.nodes.size()) held_until_.assign(g.nodes.size(), -kNever);
  if (seen_epoch_.size() != g.nodes.size()) seen_epoch_.assign(g.nodes.size(), ~std::uint64_t{0});
  if (wake_at_.size() != g.nodes.size()) wake_at_.assign(g.nodes.size(), -kNever);
  if (merged_into_.size() != g.nodes.size()) merged_into_.assign(g.nodes.size(), 1);
  // Rays merged into a queued job change what its node's plan would find (rule 4's sizes,
  // rule 3's order).
  const std::vector<JobId>& merged = pool.merged();
  for (; merged_seen_ < merged.size(); ++merged_seen_) {
    const JobId j = merged[merged_seen_];
    // (A job not bucketed yet is new when it is; its home is not asked early, as home()
    // decides it from where its rays are.)
    if (pool.state(j) != JobState::Queued || pool.queue_number(j) >= bucketed_) continue;
    const NodeId h = static_cast<std::size_t>(j) < homes_.size() ? homes_[static_cast<std::size_t>(j)] : kNone;
    if (h == kNone) std::fill(merged_into_.begin(), merged_into_.end(), 1);
    else merged_into_[static_cast<std::size_t>(h)] = 1;
  }
  // A bucket holds entries gone stale only once one of its jobs left the queue: the nodes
  // whose buckets need pruning (a skipped node prunes only then, as its plan would).
  if (stale_.size() != g.nodes.size()) stale_.assign(g.nodes.size(), 1);
  const std::vector<JobId>& left = pool.left_queue();
  for (; left_seen_ < left.size(); ++left_seen_) {
    const auto j = static_cast<std::size_t>(left[left_seen_]);
    if (j < homes_.size() && homes_[j] != kNone) stale_[static_cast<std::size_t>(homes_[j])] = 1;
  }
  for (JobId j : pool.queued_since(bucketed_)) {
    const NodeId h = home(j, pool, s);
    const std::size_t k = h == kNone ? g.nodes.size() : static_cast<std::size_t>(h);
    by_node_[k].push_back({j, pool.queue_number(j)});
    fresh_[k] = true;
  }
  bucketed_ = pool.appended();
  // A node is planned when a device wants work and it has jobs: new ones, or held ones
  // whose recheck time came (a pass that left jobs queued looks again after `hold` / 4), or
  // an idle device while something on the node changed since its last plan (new jobs, an
  // activity there started, ended or was committed, data came or went, rays merged into
  // its jobs, a job held for a time may go): with nothing changed the plan would find
  // what the last one found.
  const std::size_t any_bucket = g.nodes.size();
  const bool drained = s.unfinished() == 0;
  std::vector<std::size_t>& todo = todo_;
  todo.clear();
  // New jobs are looked at no more than once per `slack`; held ones once their recheck came.
  auto due = [&](std::size_t n) {
    return (fresh_[n] || fresh_[any_bucket]) ? now >= planned_at_[n] + opt_.slack : now >= recheck_[n];
  };
  for (std::size_t n = 0; n < g.nodes.size(); ++n) {
    if (by_node_[n].empty() && by_node_[any_bucket].empty()) continue;
    // New jobs are looked at no more than once per `slack` unless a device is idle, or
    // nothing at all is in flight (no later event would call again).
    if (!due(n) && !drained && (idle(n) == 0 || now < held_until_[n])) continue;
    if (wants_work(n)) todo.push_back(n);
  }
  if (todo.empty()) return done();
  // Reality into the timelines (Schedule::reproject walks every unfinished activity): at
  // most once per hundredth of the horizon; in between, plans use the last projection.
  if (now >= reprojected_ + 0.01 * opt_.horizon || now < reprojected_) {
    s.reproject(now);
    reprojected_ = now;
  }
  // A node planned only for an idle device, with nothing changed since its last plan, is
  // planned as it was: only its clocks and buckets move, as a plan's would.
  std::size_t kept = 0;
  for (const std::size_t n : todo) {
    const bool changed = fresh_[n] || fresh_[any_bucket] || s.node_epoch(static_cast<NodeId>(n)) != seen_epoch_[n] ||
                         merged_into_[n] || now >= wake_at_[n];
    if (due(n) || drained || changed || !opt_.skip_unchanged) {
      todo[kept++] = n;
      continue;
    }
    if (stale_[n] || !by_node_[any_bucket].empty() || s.any_lost()) scan_buckets(n, pool, s, [](const Queued) {});
    stale_[n] = 0;
    ++skipped_;
    planned_at_[n] = now;
    recheck_[n] = now + 0.25 * opt_.hold;
  }
  todo.resize(kept);
  placer_->finder().clear();
  placer_->finder().set_now(now);
  placer_->finder().set_scene_from_origin_or_local(true);  // rule 1: no scene data between nodes
  // Lower bounds that cut the fetch-path searches and answer a ray queue's one direct hop
  // at once (GMB's; the same arrivals and paths as plain searches, sched/sdc/README.md).
  fetch_bound_->reset();
  placer_->finder().set_bounds(fetch_bound_.get());
  for (std::size_t n : todo) {
    fresh_[n] = false;
    planned_at_[n] = now;
    // What the plan itself commits counts as a change: data it brings can make other jobs
    // of the node placeable at its next plan.
    seen_epoch_[n] = s.node_epoch(static_cast<NodeId>(n));
    stale_[n] = 0;  // (plan_node's scan prunes its bucket)
    plan_node(n, now, pool, s, st);
    // A device planned to the horizon's end takes more once the horizon moves past it; jobs
    // rule 4 held while the node was busy may go once a device is free.
    for (const auto& [ready, d] : devices_) {
      if (ready >= now + opt_.horizon) wake_at_[n] = std::min(wake_at_[n], ready - opt_.horizon);
      if (held_while_busy_ && ready > now) wake_at_[n] = std::min(wake_at_[n], ready);
    }
    recheck_[n] = now + 0.25 * opt_.hold;
    merged_into_[n] = 0;
  }
  fresh_[any_bucket] = false;
  return done();
}

// The live jobs of node n's bucket, then those of the any-node bucket whose home is n, to
// `visit`, in bucket order; entries gone stale (planned, or queued again later) drop out,
// and any-node entries whose home is known now move to their node's bucket.
template <class Visit>
void RaylineScheduler::scan_buckets(std::size_t n, JobPool& pool, const Schedule& s, Visit&& visit) {
  const std::size_t any_bucket = by_node_.size() - 1;
  for (const std::size_t k : {n, any_bucket}) {
    std::vector<Queued>& bucket = by_node_[k];
    std::size_t keep = 0;
    for (std::size_t i = 0; i < bucket.size(); ++i) {
      const Queued q = bucket[i];
      if (pool.queue_number(q.job) != q.number) continue;  // planned, or queued again later
      if (k == any_bucket) {
        if (const NodeId h = home(q.job, pool, s); h != kNone) {
          by_node_[static_cast<std::size_t>(h)].push_back(q);
          if (static_cast<std::size_t>(h) != n) continue;
        } else {
          bucket[keep++] = q;
        }
      } else {
        bucket[keep++] = q;
      }
      visit(q);
    }
    bucket.resize(keep);
  }
}

void RaylineScheduler::plan_node(std::size_t n, Time now, JobPool& pool, Schedule& s, PlanStats& st) {
  const DeviceGraph& g = s.graph();
  const Time limit = now + opt_.horizon;
  devices_.clear();
  for (DeviceId d : g.nodes[n].computes)
    if (s.compute_alive(d)) devices_.push_back({free_at(d, now, s), d});
  std::sort(devices_.begin(), devices_.end());
  // Rule 4 holds rays back only while the node has other work: an idle device takes them.
  const bool idle = !devices_.empty() && devices_.front().first <= now;
  const bool node_busy = !devices_.empty() && devices_.back().first > now;  // rule 4, every ray job
  held_until_[n] = -kNever;
  wake_at_[n] = kNever;
  held_while_busy_ = false;
  auto wake = [&](Time t) { wake_at_[n] = std::min(wake_at_[n], t); };
  cand_.clear();
  scan_buckets(n, pool, s, [&](const Queued q) {
    const std::vector<BlockId>& scene_in = inputs_.of(q.job, pool).scene;
    bool resident = true;  // every scene input on one of this node's working memories
    for (BlockId b : scene_in) {
      bool here = false;
      for (MemId m : g.nodes[n].memories)
        if (g.memories[m].kind != MemoryKind::Disk && s.copy_at(b, m)) here = true;
      resident = resident && here;
    }
    const Bytes rays = inputs_.rays(q.job, pool);
    // Rule 4: rays on another node wait to be worth a transfer.
    const NodeId at = rays_at_[static_cast<std::size_t>(q.job)];
    if (!idle && at != kNone && static_cast<std::size_t>(at) != n && rays < opt_.min_remote_bytes &&
        now - pool.job(q.job).created < opt_.hold) {
      wake(pool.job(q.job).created + opt_.hold);
      held_while_busy_ = true;
      return;
    }
    // Rule 4, every ray job (with "hold" or rule 8 on): it waits to hold min_local_bytes
    // (or `hold`), its rays here or elsewhere, idle devices or not, while a device of its
    // node runs something (a later event plans again; a node with every device idle takes
    // what there is); its node is planned again when it may go.
    if (node_busy && opt_.min_local_bytes > 0 && rays < opt_.min_local_bytes && !scene_in.empty() &&
        now - pool.job(q.job).created < opt_.hold) {
      const Time until = pool.job(q.job).created + opt_.hold;
      held_until_[n] = held_until_[n] == -kNever ? until : std::min(held_until_[n], until);
      wake(until);
      held_while_busy_ = true;
      return;
    }
    cand_.push_back({q.job, resident, rays, q.number});
  });
  // Rule 3's order: resident first, then the most rays, then queue order (a heap: the
  // horizon usually fills long before the candidates run out).
  auto after = [](const Cand& a, const Cand& b) {
    if (a.resident != b.resident) return b.resident;
    if (a.rays != b.rays) return a.rays < b.rays;
    return a.number > b.number;
  };
  // With rule 5, a job whose scene block comes from the disk goes to the waiting pass, in
  // that order, after every resident one: such jobs are kept apart and ordered only if
  // the waiting pass reaches them with the disk free (below).
  far_.clear();
  if (opt_.no_waiting) {
    const auto mid = std::stable_partition(cand_.begin(), cand_.end(), [](const Cand& c) { return c.resident; });
    far_.assign(mid, cand_.end());
    cand_.erase(mid, cand_.end());
  }
  std::make_heap(cand_.begin(), cand_.end(), after);
  // Rule 3: the device that finishes j first (kNone: none can run it).
  struct Pick {
    DeviceId d = kNone;
    Time ready = 0, start = kNever, key = kNever, exec = 0;
  };
  auto holds_scene = [&](JobId j, DeviceId d) {
    for (BlockId b : inputs_.of(j, pool).scene)
      if (!s.copy_at(b, g.computes[d].memory)) return false;
    return true;
  };
  // Would bringing j's scene blocks into d's memory evict a scene block that no other
  // memory of the node holds (so that it would have to come back from the disk)?
  // Victims come in the same order whatever the room asked for, so once some room drops a
  // last copy any larger room does too: remembered per memory until a commit moves data
  // into it (a node whose threads are all busy would otherwise ask again for each of its
  // queues). A heuristic: a commit elsewhere may change the queued demand that orders victims.
  drop_floor_.resize(g.memories.size(), kNoFloor);
  for (MemId m : g.nodes[n].memories) drop_floor_[static_cast<std::size_t>(m)] = kNoFloor;
  auto drops_last_copy = [&](JobId j, DeviceId d) {
    const MemId m = g.computes[d].memory;
    Bytes need = 0;
    for (BlockId b : inputs_.of(j, pool).scene)
      if (!s.copy_at(b, m)) need += pool.block(b).bytes;
    if (need == 0) return false;
    Bytes& floor = drop_floor_[static_cast<std::size_t>(m)];
    if (need >= floor) return true;
    const Schedule::Admission adm = s.admission(m, need, pool.job(j).inputs);
    for (const auto& [vb, vm] : adm.victims) {
      if (pool.block(vb).kind != DataKind::SceneData) continue;
      bool elsewhere = false;
      for (MemId o : g.nodes[n].memories)
        elsewhere = elsewhere || (o != vm && g.memories[o].kind != MemoryKind::Disk && s.copy_at(vb, o));
      if (!elsewhere) {
        floor = need;
        return true;
      }
    }
    return false;
  };
  // Rule 9 (room): a wave of camera rays is made only on a memory device where the rays
  // (all but scene data: nothing evicts them), the wave included, times room_factor, leave
  // room for the largest scene block. A ray job writes up to two rays per ray it reads (a
  // continuation and a shadow ray) before its input goes, so rays can triple; without the
  // rule a node's memories fill with rays that wait for blocks no memory can take any more.
  // What no eviction frees is computed once per plan of the node; waves planned and not yet
  // made count too (their rays are in no memory yet).
  rays_on_.clear();
  std::erase_if(waves_, [&](const auto& w) { return pool.state(w.first) != JobState::Planned; });
  // With nothing in flight anywhere and no wave planned, no later event would ask again:
  // one wave goes whatever the room (a memory too small for the scene then stalls the run
  // visibly, on the jobs it cannot place).
  const bool nothing_in_flight = s.unfinished() == 0;
  auto room_for = [&](MemId m, Bytes wave) {
    if (nothing_in_flight && waves_.empty()) return true;
    auto it = std::find_if(rays_on_.begin(), rays_on_.end(), [m](const auto& r) { return r.first == m; });
    if (it == rays_on_.end()) {
      Bytes scene_here = 0, rays = 0;
      for (BlockId b : scene_)
        if (s.copy_at(b, m)) scene_here += pool.block(b).bytes;
      for (const auto& [job, on] : waves_)
        if (on == m) rays += pool.job(job).expected_output_bytes;
      rays += s.used(m) - std::min(s.used(m), scene_here);
      it = rays_on_.emplace(rays_on_.end(), m, rays);
    }
    const double cap = static_cast<double>(g.memories[m].capacity);
    return cap - opt_.room_factor * static_cast<double>(it->second + wave) >= static_cast<double>(largest_scene_);
  };
  auto pick = [&](JobId j, bool resident) {
    Pick best;
    const JobTypeId type = pool.job(j).type;
    const Bytes wave = opt_.room ? pool.job(j).expected_output_bytes : 0;
    // Rule 3: among the devices whose memory holds the job's scene blocks when one can
    // take it (moving a block inside the node evicts another, which may then have to come
    // back from the disk), else among all.
    bool holder = false;
    for (const auto& [ready, d] : devices_) holder = holder || (ready < limit && g.timing.supports(d, type) && holds_scene(j, d));
    for (std::size_t i = 0; i < devices_.size(); ++i) {
      const auto [ready, d] = devices_[i];
      if (ready >= limit || !g.timing.supports(d, type) || (holder && !holds_scene(j, d))) continue;
      // A sibling thread (same memory, same model) ready no later answers the same, sooner.
      bool shadowed = false;
      for (std::size_t o = 0; o < i && !shadowed; ++o) {
        const DeviceId e = devices_[o].second;
        shadowed = g.computes[e].memory == g.computes[d].memory && g.computes[e].model == g.computes[d].model &&
                   g.timing.supports(e, type) && devices_[o].first < limit;
      }
      if (shadowed) continue;
      // A block already on the node moves inside it only if that keeps every block the
      // node holds in some memory of it.
      if (resident && !holds_scene(j, d) && drops_last_copy(j, d)) continue;
      if (wave > 0 && !room_for(g.computes[d].memory, wave)) continue;
      const Time start = placer_->earliest_start(j, d, ready, s);
      if (start == kNever) continue;
      const Time exec = Placer::exec_estimate(j, d, s);
      const Time key = opt_.completion_aware ? start + exec : ready;
      if (key < best.key) best = {d, ready, start, key, exec};
    }
    return best;
  };
  auto commit = [&](JobId j, const Pick& p) {
    if (!placer_->place(j, p.d, p.ready, now, pool, s, st)) return;
    if (const Bytes wave = pool.job(j).expected_output_bytes; opt_.room && wave > 0) {  // rule 9
      const MemId m = g.computes[p.d].memory;
      waves_.emplace_back(j, m);
      for (auto& [rm, rays] : rays_on_)
        if (rm == m) rays += wave;
    }
    // Its transfers land in its device's memory and the node's host memory: another GPU's
    // memory keeps what it found.
    for (MemId m : g.nodes[n].memories)
      if (m == g.computes[p.d].memory || g.memories[m].kind != MemoryKind::Gpu) drop_floor_[static_cast<std::size_t>(m)] = kNoFloor;
    for (auto& [ready, d] : devices_)
      if (d == p.d) ready = free_at(d, now, s);
    std::sort(devices_.begin(), devices_.end());
  };
  waiting_.clear();
  for (auto end = cand_.end(); end != cand_.begin(); --end) {
    if (devices_.empty() || devices_.front().first >= limit) return;
    std::pop_heap(cand_.begin(), end, after);
    const Pick p = pick((end - 1)->job, true);
    if (p.d == kNone) continue;
    if (opt_.no_waiting && p.start - p.ready > std::max(opt_.slack, p.exec)) {
      waiting_.push_back(*(end - 1));  // rule 5: after the jobs that start at once
      waiting_.back().device = p.d;
      waiting_.back().ready = p.ready;
      continue;
    }
    commit((end - 1)->job, p);
  }
  // Waiting jobs, in the same order. One that cannot start within the horizon (a block
  // from the disk) only once the node's previous such job has started: each holds its
  // device while the disk works.
  if (long_wait_job_.size() != g.nodes.size()) long_wait_job_.assign(g.nodes.size(), kNone);
  auto disk_free = [&] {
    if (!opt_.no_waiting) return true;
    const JobId w = long_wait_job_[n];
    return w == kNone || pool.state(w) != JobState::Planned || s.activity(pool.activity(w)).state != ActivityState::Planned;
  };
  auto wait_pass = [&](const std::vector<Cand>& jobs) {
    for (const Cand& c : jobs) {
      if (devices_.empty() || devices_.front().first >= limit) return false;
      if (!c.resident && !disk_free()) continue;
      // The first pass's pick stands while its device's timeline is as it was then.
      Pick p;
      if (c.device != kNone) {
        for (const auto& [ready, d] : devices_)
          if (d == c.device && ready == c.ready && ready < limit) p = {d, ready, ready, ready, 0};
      }
      if (p.d == kNone) p = pick(c.job, c.resident);
      if (p.d == kNone) continue;
      if (p.start >= limit) {
        if (!disk_free()) {
          wake(p.start - opt_.horizon);  // within the horizon then
          continue;
        }
        long_wait_job_[n] = c.job;
      }
      commit(c.job, p);
    }
    return true;
  };
  if (!wait_pass(waiting_) || far_.empty() || devices_.empty() || devices_.front().first >= limit) return;
  // The jobs from the disk, all skipped while the node's last one waits (nothing in the
  // pass below changes that unless one of them is committed).
  if (!disk_free()) return;
  std::sort(far_.begin(), far_.end(), [&](const Cand& a, const Cand& b) { return after(b, a); });
  wait_pass(far_);
}

}  // namespace rayline
