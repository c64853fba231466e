#include "render/mpi/mpi_executor.hpp"

#include <algorithm>
#include <chrono>
#include <span>

#include "common/error.hpp"
#include "render/engine/aggregate_factory.hpp"
#include "render/engine/render_workload.hpp"
#include "render/integrator/film.hpp"
#include "render/mpi/message.hpp"
#include "render/store/block_store.hpp"

namespace rayline::mpi {

void Pending::expect(ActivityId id, std::vector<int> ranks) {
  std::lock_guard lk(mu_);
  Slot s;
  for (int r : ranks)
    if (auto it = lost_.find(r); it != lost_.end()) s.done = true, s.ok = false, s.why = it->second;
  s.ranks = std::move(ranks);
  slots_[id] = std::move(s);
}

void Pending::fail_rank(int rank, const std::string& why) {
  {
    std::lock_guard lk(mu_);
    lost_[rank] = why;
    for (auto& [id, s] : slots_)
      if (!s.done && std::find(s.ranks.begin(), s.ranks.end(), rank) != s.ranks.end())
        s.done = true, s.ok = false, s.why = why;
  }
  cv_.notify_all();
}

Buffer Pending::wait(ActivityId id) {
  std::unique_lock lk(mu_);
  cv_.wait(lk, [&] { return slots_.at(id).done || !failed_.empty(); });
  Slot s = std::move(slots_.at(id));
  slots_.erase(id);
  if (!s.done) throw ActivityError(failed_);
  if (!s.ok) throw ActivityError(s.why);
  return std::move(s.reply);
}

void Pending::complete(ActivityId id, bool ok, const std::string& why, Buffer reply) {
  {
    std::lock_guard lk(mu_);
    auto it = slots_.find(id);
    if (it == slots_.end()) return;  // (withdrawn)
    it->second.done = true;
    it->second.ok = ok;
    it->second.why = why;
    it->second.reply = std::move(reply);
  }
  cv_.notify_all();
}

void Pending::fail_all(const std::string& why) {
  {
    std::lock_guard lk(mu_);
    failed_ = why;
  }
  cv_.notify_all();
}

ClusterTasks::ClusterTasks(Comm& comm, Node& self, const engine::ClusterWork& w, Pending& pending, ExecTime& time)
    : comm_(comm), self_(self), w_(w), pending_(pending), time_(time) {
  const engine::AggregateSources sources{w.store, w.gpu, nullptr, true};
  std::vector<int> next(w.g.nodes.size(), 0);
  for (const ComputeDevice& c : w.g.computes) {
    local_index_.push_back(next[std::size_t(c.node)]++);
    aggregates_.push_back(c.node == 0 ? engine::make_aggregate(c.kind, sources) : nullptr);
  }
}

void ClusterTasks::send(int rank, const Buffer& b) {
  try {
    comm_.send(rank, b);
  } catch (const std::runtime_error& e) {  // a lost rank: the loop re-plans the activity
    throw ActivityError(e.what());
  }
}

std::map<int, ClusterTasks::Victims> ClusterTasks::victims_of(ActivityId id) {
  const auto& evs = w_.schedule.evictions();
  for (; ev_cursor_ < evs.size(); ++ev_cursor_) {
    const Eviction& e = evs[ev_cursor_];
    const MemoryKind kind = w_.g.memories[std::size_t(e.mem)].kind;
    if (kind == MemoryKind::Disk) continue;
    Victims& v = victims_[e.for_activity][rank_of(e.mem)];
    const auto it = w_.cell_of.find(e.block);
    if (kind == MemoryKind::Host) {
      if (it != w_.cell_of.end()) v.cells.push_back(it->second);
      else v.queues.push_back(e.block);
    } else {
      if (it != w_.cell_of.end()) v.gpu_cells.push_back(it->second);
      else v.gpu_queues.push_back(e.block);
    }
  }
  std::map<int, Victims> v;
  if (auto it = victims_.find(id); it != victims_.end()) {
    v = std::move(it->second);
    victims_.erase(it);
  }
  return v;
}

// Rank 0's queues in RAM live in the workload's jobs: nothing to free there.
void ClusterTasks::evict_here(const Victims& v) {
  for (std::uint32_t c : v.cells) w_.store.evict(c);
  if (!w_.gpu) return;
  for (std::uint32_t c : v.gpu_cells) w_.gpu->evict(c);
  for (std::int32_t q : v.gpu_queues) w_.gpu->drop_rays(q);
}

Writer& ClusterTasks::with_victims(Writer& w, const Victims& v) {
  return w.records(v.cells).records(v.queues).records(v.gpu_cells).records(v.gpu_queues);
}

void ClusterTasks::evict_elsewhere(ActivityId id, std::map<int, Victims>& v, int main) {
  for (auto& [rank, vic] : v) {
    if (rank == main) continue;
    if (rank == 0) {
      evict_here(vic);
      continue;
    }
    Header h;
    h.op = Op::Evict;
    h.activity = id;
    Writer w(h);
    with_victims(w, vic);
    pending_.expect(id, {rank});
    send(rank, w.buffer());
    pending_.wait(id);
  }
}

engine::LocalExecutor::Task ClusterTasks::task(ActivityId id, const Activity& a) {
  auto v = victims_of(id);
  if (a.kind == ActivityKind::Exec) return exec(id, a, std::move(v));
  return transfer(id, a, std::move(v));
}

engine::LocalExecutor::Task ClusterTasks::exec(ActivityId id, const Activity& a, std::map<int, Victims> v) {
  engine::RayJob* job = &w_.workload.job(a.job);
  const int rank = int(w_.g.computes[std::size_t(a.device)].node);
  if (rank == 0) {
    accel::Aggregate* aggregate = aggregates_.at(std::size_t(a.device)).get();
    return [this, id, job, aggregate, v = std::move(v)]() mutable {
      evict_elsewhere(id, v, -1);
      const auto t0 = std::chrono::steady_clock::now();
      aggregate->intersect(w_.ts, accel::QueueJob{job->cell, static_cast<trace::RayKind>(job->slot % 2), job->rays, job->parts},
                           job->out, job->counts);
      std::vector<trace::RayRecord>().swap(job->rays);
      ++self_.execs;
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      time_.add(0, s, s);
    };
  }
  const int device = local_index_.at(std::size_t(a.device));
  return [this, id, job, rank, device, v = std::move(v)]() mutable {
    const auto t0 = std::chrono::steady_clock::now();
    evict_elsewhere(id, v, rank);
    Header h;
    h.op = Op::Exec;
    h.activity = id;
    h.cell = job->cell;
    h.device = device;
    h.slot = job->slot;
    Writer w(h);
    std::vector<Part> parts;
    for (const auto& [q, n] : job->parts) parts.push_back({q, n});
    with_victims(w, v[rank]).records(parts);
    pending_.expect(id, {rank});
    send(rank, w.buffer());
    const Buffer reply = pending_.wait(id);
    Reader r(reply);
    r.text();
    job->counts = r.value<trace::RayCounts>();
    job->out = r.records<trace::RayRecord>();
    const auto entries = r.records<trace::FilmEntry>();
    const auto dropped = r.value<std::uint64_t>(), clamped = r.value<std::uint64_t>();
    w_.ts.film->apply(entries, dropped, clamped);
    time_.add(rank, r.value<double>(), std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    std::vector<trace::RayRecord>().swap(job->rays);
  };
}

engine::LocalExecutor::Task ClusterTasks::transfer(ActivityId id, const Activity& a, std::map<int, Victims> v) {
  const Channel& ch = w_.g.channels[std::size_t(a.channel)];
  const MemoryDevice& from = w_.g.memories[std::size_t(ch.from)];
  const MemoryDevice& to = w_.g.memories[std::size_t(ch.to)];
  const int src = int(from.node), dst = int(to.node);
  const auto cit = w_.cell_of.find(a.block);
  const bool scene = cit != w_.cell_of.end();
  const std::uint32_t cell = scene ? cit->second : 0;
  const bool load = scene && from.kind == MemoryKind::Disk && to.kind == MemoryKind::Host;
  const bool lan = from.kind == MemoryKind::Host && to.kind == MemoryKind::Host && src != dst;
  const bool upload = from.kind == MemoryKind::Host && to.kind == MemoryKind::Gpu;
  // The rays of a ray queue leaving rank 0: those of the job that consumes it.
  const std::span<const trace::RayRecord> rays =
      (lan || upload) && !scene && src == 0 ? w_.workload.queue_rays(a.block) : std::span<const trace::RayRecord>{};
  return [=, this, v = std::move(v)]() mutable {
    const int main = load || upload ? src : (lan ? dst : -1);
    evict_elsewhere(id, v, main);
    if (upload && src == 0) {  // rank 0's GPU (activity_tasks.cpp does the same on one machine)
      evict_here(v[0]);
      if (scene) w_.gpu->load(cell);
      else if (!rays.empty()) w_.gpu->load_rays(a.block, rays, w_.ts);
      return;
    }
    if (load && src == 0) {
      evict_here(v[0]);
      try {
        w_.store.load(cell);
      } catch (const InputError& e) {
        throw ActivityError(e.what(), std::current_exception());
      }
      return;
    }
    if (!load && !lan && !upload) return;  // (nothing else moves data in the renderer's plans)
    Header h;
    h.activity = id;
    h.cell = cell;
    h.block = a.block;
    h.dest = dst;
    // A ray queue rank 0 sends needs no answer: the receiver stores it as it arrives, before
    // any later message from rank 0 (MPI keeps a pair's messages in order), so the T-job is
    // done once the bytes have left.
    h.device = scene ? 1 : (src == 0 ? 2 : 0);
    if (load) {
      h.op = Op::Load;
    } else if (upload) {
      h.op = Op::Upload;
    } else if (src == 0) {  // rank 0 sends the data itself
      h.op = Op::Data;
    } else {  // another rank sends it
      h.op = Op::Send;
    }
    Writer w(h);
    const int victims_rank = load || upload ? src : dst;
    with_victims(w, v[victims_rank]);
    if (h.op == Op::Data) {
      if (scene) w.records(w_.store.get(cell)->records());
      else w.records(rays);
      if (scene) ++self_.scene_out;
      else ++self_.queues_out;
    }
    if (h.device == 2) {
      send(dst, w.buffer());
      return;
    }
    pending_.expect(id, {src, dst});
    send(h.op == Op::Data ? dst : src, w.buffer());  // (Load, Upload, Send: to src)
    pending_.wait(id);
  };
}

engine::LocalExecutor::Task ClusterTasks::hint(ActivityId, const Activity& a) const {
  if (a.kind != ActivityKind::Transfer || !w_.read_ahead) return {};
  const Channel& ch = w_.g.channels[std::size_t(a.channel)];
  if (w_.g.memories[std::size_t(ch.from)].kind != MemoryKind::Disk ||
      w_.g.memories[std::size_t(ch.from)].node != 0)
    return {};
  const auto it = w_.cell_of.find(a.block);
  if (it == w_.cell_of.end()) return {};
  engine::BlockStore* store = &w_.store;
  return [store, cell = it->second] { store->read_ahead(cell); };
}

MpiExecutor::MpiExecutor(const DeviceGraph& g, std::unique_ptr<ClusterTasks> tasks, Pending& pending)
    : engine::LocalExecutor(
          g, [t = tasks.get()](ActivityId id, const Activity& a) { return t->task(id, a); },
          [t = tasks.get()](ActivityId id, const Activity& a) { return t->hint(id, a); }),
      pending_(pending), tasks_(std::move(tasks)) {}

MpiExecutor::~MpiExecutor() { pending_.fail_all("the render ended"); }

}  // namespace rayline::mpi
