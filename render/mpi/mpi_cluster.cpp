#include "render/mpi/mpi_cluster.hpp"

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <tuple>

#include "render/engine/renderer.hpp"
#include "render/mpi/lan_calibration.hpp"
#include "render/mpi/message.hpp"
#include "render/store/block_store.hpp"

namespace rayline::mpi {

namespace {

Buffer stats_message(Node& n, const Comm& comm, const std::string& host) {
  Header h;
  h.op = Op::Stats;
  Writer w(h);
  const auto st = n.store().stats();
  const std::uint64_t v[] = {n.execs,     st.loads,   st.evictions, st.bytes_read, n.scene_in,
                             n.scene_out, n.queues_in, n.queues_out, n.gpu_jobs()};
  std::vector<std::uint64_t> traffic;
  for (int r = 0; r < comm.size(); ++r) {
    traffic.push_back(comm.sent_to(r).messages);
    traffic.push_back(comm.sent_to(r).bytes);
  }
  w.records(std::span<const std::uint64_t>(v)).records(traffic).text(host);
  return std::move(w.buffer());
}

engine::RankStats read_stats(const Buffer& m) {
  Reader r(m);
  engine::RankStats s;
  const auto v = r.records<std::uint64_t>();
  if (v.size() != 9) throw std::runtime_error("MPI message: bad Stats");
  s.execs = v[0], s.loads = v[1], s.evictions = v[2], s.bytes_read = v[3];
  s.scene_in = v[4], s.scene_out = v[5], s.queues_in = v[6], s.queues_out = v[7], s.gpu_jobs = v[8];
  const auto traffic = r.records<std::uint64_t>();
  for (std::size_t i = 0; i + 1 < traffic.size(); i += 2) s.messages_sent += traffic[i], s.bytes_sent += traffic[i + 1];
  s.host = r.text();
  return s;
}
}  // namespace

MpiCluster::MpiCluster(const Session& s) : session_(s), comm_(s), stats_(std::size_t(s.size())) {
  // The LAN as rank 0 sees it (lan_calibration.hpp): the worst pair with each rank.
  if (s.size() == 1) return;
  lan_.latency = 0;
  lan_.bandwidth = 0;
  for (int r = 1; r < s.size(); ++r) {
    if (s.rank() == 0) {
      const auto [latency, bandwidth] = measure_pair(comm_, r);
      lan_.latency = std::max(lan_.latency, latency);
      lan_.bandwidth = lan_.bandwidth > 0 ? std::min(lan_.bandwidth, bandwidth) : bandwidth;
    } else if (s.rank() == r) {
      echo_pair(comm_, 0);
    }
  }
}

MpiCluster::~MpiCluster() {
  stop_watch_ = true;
  if (watchdog_.joinable()) watchdog_.join();
  if (session_.rank() == 0 && ready_ >= 0) {  // a run that ended early: the others stop too
    Header h;
    h.op = Op::Stop;
    for (int r = 1; r < ranks(); ++r) try {
        comm_.send(r, Writer(h).buffer());
      } catch (const std::exception&) {  // (a lost rank)
      }
  }
  pending_.fail_all("the render ended");
  comm_.stop();
}

int MpiCluster::live_ranks() const {
  int n = 0;
  for (int r = 0; r < ranks(); ++r) n += !comm_.lost(r);
  return n;
}

void MpiCluster::lose(int rank) {
  Header out;
  out.op = Op::Lost;
  out.dest = rank;
  comm_.send_anyway(rank, Writer(out).buffer(), 0.5);  // (alive but too slow: it stops serving)
  comm_.mark_lost(rank);
  const std::string why = "rank " + std::to_string(rank) + " (R" + std::to_string(rank) + ") stopped answering";
  std::fprintf(stderr, "rayline: %s for %.0f s: its work is planned again on the other ranks\n", why.c_str(), kSilence);
  {
    std::lock_guard lk(mu_);
    lost_.push_back(rank);
    lost_new_.push_back(rank);
    cv_.notify_all();
  }
  pending_.fail_rank(rank, why);
  Header h;
  h.op = Op::Lost;
  h.dest = rank;
  for (int r = 1; r < ranks(); ++r)
    if (!comm_.lost(r)) try {
        comm_.send(r, Writer(h).buffer());
      } catch (const std::exception&) {
      }
  if (executor_) executor_->wake_at(executor_->now());
}

void MpiCluster::watch() {
  while (!stop_watch_) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    for (int r = 1; r < ranks(); ++r)
      if (!comm_.lost(r) && comm_.silent_for(r) > kSilence) lose(r);
  }
}

std::vector<int> MpiCluster::take_lost() {
  std::lock_guard lk(mu_);
  std::vector<int> v;
  v.swap(lost_new_);
  return v;
}

int MpiCluster::default_threads() const {
  const int hw = std::max(1, int(std::thread::hardware_concurrency()));
  return std::max(1, hw / std::max(1, session_.local_size()));
}

void MpiCluster::on_message(int source, Buffer m) {
  Reader r(m);
  const Header h = r.header();
  switch (h.op) {
    case Op::Done:
      if (h.activity < 0) {  // Setup acknowledged
        std::lock_guard lk(mu_);
        ++ready_;
        cv_.notify_all();
        return;
      } else {
        const std::string why = r.text();
        pending_.complete(h.activity, h.ok != 0, why, std::move(m));
      }
      return;
    case Op::Stats: {
      std::lock_guard lk(mu_);
      stats_.at(std::size_t(source)) = read_stats(m);
      ++ready_;
      cv_.notify_all();
      return;
    }
    case Op::Heartbeat: return;
    case Op::Fatal: {
      const std::string why = "rank " + std::to_string(source) + ": " + r.text();
      {
        std::lock_guard lk(mu_);
        fatal_ = why;
        cv_.notify_all();
      }
      pending_.fail_all(why);
      return;
    }
    default:
      if (self_) self_->handle(source, std::move(m));
  }
}

void MpiCluster::start(const engine::ClusterFrame& f) {
  comm_.start([this](int source, Buffer m) { on_message(source, std::move(m)); });
  const Buffer setup = encode_frame(f);
  for (int r = 1; r < ranks(); ++r) comm_.send(r, setup);
  watchdog_ = std::thread([this] { watch(); });
  std::unique_lock lk(mu_);
  cv_.wait(lk, [&] { return ready_ + int(lost_.size()) >= ranks() - 1 || !fatal_.empty(); });
  if (!fatal_.empty()) throw std::runtime_error(fatal_);
  frame_ = f;
}

std::unique_ptr<engine::LocalExecutor> MpiCluster::executor(const engine::ClusterWork& w) {
  self_ = std::make_unique<Node>(comm_, frame_, &w.store, w.gpu);
  self_->on_local_done = [this](int activity, bool ok, const std::string& why) { pending_.complete(activity, ok, why); };
  auto e = std::make_unique<MpiExecutor>(w.g, std::make_unique<ClusterTasks>(comm_, *self_, w, pending_, exec_time_), pending_);
  executor_ = e.get();
  return e;
}

void MpiCluster::finish(engine::RenderResult& res) {
  {
    std::lock_guard lk(mu_);
    ready_ = 0;
  }
  Header h;
  h.op = Op::Stop;
  for (int r = 1; r < ranks(); ++r)
    if (!comm_.lost(r)) try {
        comm_.send(r, Writer(h).buffer());
      } catch (const std::exception&) {
      }
  {
    std::unique_lock lk(mu_);
    cv_.wait(lk, [&] { return ready_ + int(lost_.size()) >= ranks() - 1 || !fatal_.empty(); });
    if (!fatal_.empty()) throw std::runtime_error(fatal_);
    ready_ = -1;  // stopped: nothing more to send
  }
  self_->drain();
  stats_[0] = read_stats(stats_message(*self_, comm_, session_.host()));
  for (int r : lost_) stats_[std::size_t(r)].lost = true;
  for (int r = 0; r < ranks(); ++r) std::tie(stats_[std::size_t(r)].exec_traced_seconds, stats_[std::size_t(r)].exec_seen_seconds) = exec_time_.of(r);
  res.ranks = stats_;
  executor_ = nullptr;
  res.lan = lan_;
}

int MpiCluster::serve() {
  std::mutex mu;
  std::condition_variable cv;
  bool stop = false;
  std::thread killer;
  comm_.start([&](int source, Buffer m) {
    const Header h = Reader(m).header();
    if (h.op == Op::Lost && h.dest == session_.rank()) {  // rank 0 gave up on this rank: it stops
      comm_.mark_lost(0);
      std::lock_guard lk(mu);
      stop = true;
      cv.notify_all();
      return;
    }
    if (h.op == Op::Lost) {
      comm_.mark_lost(h.dest);
      return;
    }
    if (h.op == Op::Setup && fail_rank_ == session_.rank())
      killer = std::thread([s = fail_at_] {
        std::this_thread::sleep_for(std::chrono::duration<double>(s));
        ::raise(SIGKILL);
      });
    if (h.op == Op::Setup) {
      Header d;
      d.op = Op::Done;
      try {
        self_ = std::make_unique<Node>(comm_, decode_frame(m));
        Writer w(d);
        comm_.send(0, w.text("").buffer());
      } catch (const std::exception& e) {
        d.op = Op::Fatal;
        Writer w(d);
        comm_.send(0, w.text(e.what()).buffer());
      }
      return;
    }
    if (h.op == Op::Stop) {
      if (self_) {
        self_->drain();
        comm_.send(0, stats_message(*self_, comm_, session_.host()));
      }
      std::lock_guard lk(mu);
      stop = true;
      cv.notify_all();
      return;
    }
    if (self_) self_->handle(source, std::move(m));
  });
  // Heartbeats: rank 0 takes a rank silent for kSilence seconds as lost.
  std::unique_lock lk(mu);
  Header beat;
  beat.op = Op::Heartbeat;
  while (!cv.wait_for(lk, std::chrono::milliseconds(250), [&] { return stop; })) {
    lk.unlock();
    try {
      comm_.send(0, Writer(beat).buffer());
    } catch (const std::exception&) {
    }
    lk.lock();
  }
  lk.unlock();
  comm_.stop();
  self_.reset();
  if (killer.joinable()) killer.detach();
  return 0;
}

}  // namespace rayline::mpi
