#include "render/mpi/node.hpp"

#include <xmmintrin.h>
#include <pmmintrin.h>

#include <chrono>

#include "common/error.hpp"
#include "render/engine/aggregate_factory.hpp"
#include "render/engine/gpu_select.hpp"
#include "render/integrator/film.hpp"
#include "render/mpi/message.hpp"

namespace rayline::mpi {

Buffer encode_frame(const engine::ClusterFrame& f) {
  Header h;
  h.op = Op::Setup;
  Writer w(h);
  const std::int64_t ints[] = {f.width, f.height, f.spp, f.max_depth, f.threads, f.build_threads, f.quality,
                               std::int64_t(f.seed), f.skip_empty, f.continue_in_cell};
  w.text(f.scene).text(f.blocks_dir).records(std::span<const std::int64_t>(ints)).records(f.footprint).text(f.gpu);
  return std::move(w.buffer());
}

engine::ClusterFrame decode_frame(const Buffer& b) {
  Reader r(b);
  engine::ClusterFrame f;
  f.scene = r.text();
  f.blocks_dir = r.text();
  const auto v = r.records<std::int64_t>();
  if (v.size() != 10) throw std::runtime_error("MPI message: bad Setup");
  f.width = int(v[0]), f.height = int(v[1]), f.spp = int(v[2]), f.max_depth = int(v[3]), f.threads = int(v[4]);
  f.build_threads = int(v[5]), f.quality = int(v[6]), f.seed = std::uint64_t(v[7]), f.skip_empty = v[8] != 0;
  f.continue_in_cell = v[9] != 0;
  f.footprint = r.records<std::uint64_t>();
  f.gpu = r.text();
  return f;
}

Node::Node(Comm& comm, const engine::ClusterFrame& f, engine::BlockStore* store, engine::GpuStore* gpu)
    : comm_(comm), frame_(f), store_(store), gpu_(gpu) {
  if (store_) return;  // rank 0: the renderer's store; its own threads trace (ClusterTasks)
  scene_ = f.scene.empty() ? scene::default_scene() : scene::load_scene(f.scene);
  index_ = partition::load_block_index(f.blocks_dir);
  if (index_.blocks.size() != f.footprint.size()) throw std::runtime_error("blocks.json differs between ranks");
  own_store_ = std::make_unique<engine::BlockStore>(index_, f.blocks_dir, f.footprint,
                                                    static_cast<std::uint32_t>(scene_.materials.size()),
                                                    static_cast<trace::BvhQuality>(f.quality), f.build_threads);
  store_ = own_store_.get();
  ts_.scene = &scene_;
  ts_.cells = &index_;
  ts_.set_bounds(index_.bounds);
  ts_.seed = f.seed;
  ts_.max_depth = f.max_depth;
  ts_.skip_empty = f.skip_empty;
  ts_.continue_in_cell = f.continue_in_cell;
  if (!f.gpu.empty()) {  // every node has rank 0's GPU (the graph is homogeneous)
    std::string status;
    gpu_ctx_ = engine::select_gpu(f.gpu, status);
    if (!gpu_ctx_)
      throw std::runtime_error("no Vulkan device '" + f.gpu + "' here, as rank 0 has (" + status + ")");
    own_gpu_ = std::make_unique<engine::GpuStore>(*gpu_ctx_, *store_);
    gpu_ = own_gpu_.get();
  }
  const engine::AggregateSources sources{*store_, gpu_, nullptr, true};
  for (int t = 0; t < f.threads; ++t) aggregates_.push_back(engine::make_aggregate(ComputeKind::Cpu, sources));
  if (gpu_) aggregates_.push_back(engine::make_aggregate(ComputeKind::Gpu, sources));
}

Node::~Node() { drain(); }

void Node::drain() {
  std::vector<std::future<void>> w;
  {
    std::lock_guard lk(mu_);
    w.swap(work_);
  }
  for (auto& f : w) f.wait();
}

void Node::spawn(std::int32_t activity, std::function<void()> work) {
  std::lock_guard lk(mu_);
  std::erase_if(work_, [](std::future<void>& f) { return f.wait_for(std::chrono::seconds(0)) == std::future_status::ready; });
  work_.push_back(std::async(std::launch::async, [this, activity, w = std::move(work)] {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);  // as LocalExecutor's tracing threads
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
    try {
      w();
    } catch (const std::exception& e) {  // reported, so that the master's lane never waits forever
      done(activity, false, std::string("rank ") + std::to_string(comm_.rank()) + ": " + e.what());
    }
  }));
}

void Node::done(std::int32_t activity, bool ok, const std::string& why, Buffer* payload) {
  if (comm_.rank() == 0) {
    if (on_local_done) on_local_done(activity, ok, why);
    return;
  }
  if (payload) {
    comm_.send(0, *payload);
    return;
  }
  Header h;
  h.op = Op::Done;
  h.activity = activity;
  h.ok = ok;
  Writer w(h);
  w.text(why);
  comm_.send(0, w.buffer());
}

std::vector<trace::RayRecord> Node::queue(std::int32_t block) {
  std::lock_guard lk(mu_);
  auto it = queues_.find(block);
  return it == queues_.end() ? std::vector<trace::RayRecord>{} : it->second;
}

// Every command starts with the evictions of its activity on this rank: scene blocks (cells)
// and ray queues leaving its RAM, then its GPU's memory.
void Node::evict(Reader& r) {
  for (std::uint32_t c : r.records<std::uint32_t>()) store_->evict(c);
  const auto queues = r.records<std::int32_t>();
  const auto gpu_cells = r.records<std::uint32_t>();
  const auto gpu_queues = r.records<std::int32_t>();
  if (gpu_) {
    for (std::uint32_t c : gpu_cells) gpu_->evict(c);
    for (std::int32_t q : gpu_queues) gpu_->drop_rays(q);
  }
  std::lock_guard lk(mu_);
  for (std::int32_t q : queues) queues_.erase(q);
}

void Node::upload(const Buffer& m) {
  Reader r(m);
  const Header h = r.header();
  evict(r);
  if (!gpu_) throw std::runtime_error("a GPU T-job on a rank without a GPU");
  if (h.device == 1) {
    gpu_->load(h.cell);
  } else {
    const auto rays = queue(h.block);  // (arrived over the LAN before this message)
    if (!rays.empty()) gpu_->load_rays(h.block, rays, ts_);
  }
  done(h.activity, true, "");
}

void Node::load(const Buffer& m) {
  Reader r(m);
  const Header h = r.header();
  evict(r);
  try {
    store_->load(h.cell);
    done(h.activity, true, "");
  } catch (const InputError& e) {  // a read error: the master plans the load again
    done(h.activity, false, e.what());
  }
}

void Node::exec(const Buffer& m) {
  Reader r(m);
  const Header h = r.header();
  evict(r);
  std::vector<std::pair<BlockId, std::uint32_t>> parts;
  for (const Part& p : r.records<Part>()) parts.emplace_back(p.block, p.rays);
  std::vector<trace::RayRecord> rays;
  {
    std::lock_guard lk(mu_);
    for (const auto& [q, n] : parts) {
      auto it = queues_.find(q);
      if (it == queues_.end() || it->second.size() != n) {
        rays.clear();
        break;
      }
      rays.insert(rays.end(), it->second.begin(), it->second.end());
      queues_.erase(it);
    }
  }
  std::size_t want = 0;
  for (const auto& p : parts) want += p.second;
  if (rays.size() != want) {
    done(h.activity, false, "rank " + std::to_string(comm_.rank()) + " lacks a ray queue of the job");
    return;
  }
  trace::Film journal = trace::Film::journal();
  trace::TraceSettings ts = ts_;
  ts.film = &journal;
  std::vector<trace::RayRecord> out;
  trace::RayCounts counts;
  const auto t0 = std::chrono::steady_clock::now();
  aggregates_.at(std::size_t(h.device))
      ->intersect(ts, accel::QueueJob{h.cell, static_cast<trace::RayKind>(h.slot % 2), rays, parts}, out, counts);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  Header d;
  d.op = Op::Done;
  d.activity = h.activity;
  Writer w(d);
  ++execs;
  w.text("").value(counts).records(out).records(journal.take_journal()).value(journal.dropped()).value(journal.clamped());
  w.value(seconds);
  done(h.activity, true, "", &w.buffer());
}

void Node::send(const Buffer& m) {
  Reader r(m);
  Header h = r.header();
  const auto ram_cells = r.records<std::uint32_t>();  // the receiver's evictions, forwarded
  const auto queues = r.records<std::int32_t>();
  const auto gpu_cells = r.records<std::uint32_t>();
  const auto gpu_queues = r.records<std::int32_t>();
  try {
    h.op = Op::Data;
    Writer w(h);
    w.records(ram_cells).records(queues).records(gpu_cells).records(gpu_queues);
    if (h.device == 1) {
      w.records(store_->get(h.cell)->records());
      ++scene_out;
    } else {
      const auto rays = queue(h.block);
      w.records(rays);
      ++queues_out;
    }
    comm_.send(h.dest, w.buffer());
  } catch (const std::exception& e) {
    done(h.activity, false, e.what());
  }
}

void Node::data(const Buffer& m) {
  Reader r(m);
  const Header h = r.header();
  evict(r);
  try {
    if (h.device == 1) {
      store_->insert(h.cell, r.bytes());
      ++scene_in;
    } else {
      auto rays = r.records<trace::RayRecord>();
      ++queues_in;
      std::lock_guard lk(mu_);
      queues_[h.block] = std::move(rays);
    }
    if (h.device != 2) done(h.activity, true, "");
  } catch (const std::exception& e) {
    done(h.activity, false, e.what());
  }
}

bool Node::handle(int, Buffer message) {
  Reader r(message);
  const Header h = r.header();
  switch (h.op) {
    case Op::Load: spawn(h.activity, [this, m = std::move(message)] { load(m); }); return true;
    case Op::Exec: spawn(h.activity, [this, m = std::move(message)] { exec(m); }); return true;
    case Op::Upload: spawn(h.activity, [this, m = std::move(message)] { upload(m); }); return true;
    case Op::Send: spawn(h.activity, [this, m = std::move(message)] { send(m); }); return true;
    case Op::Data:
      if (h.device == 1) spawn(h.activity, [this, m = std::move(message)] { data(m); });
      else data(message);  // a ray queue: stored here, in arrival order (before the Exec that needs it)
      return true;
    case Op::Evict:
      evict(r);
      done(h.activity, true, "");
      return true;
    default: return false;
  }
}

}  // namespace rayline::mpi
