// `rayline render --distributed` under mpirun (render/mpi/README.md): rank 0 renders with
// an MpiCluster as RenderOptions::cluster; every other rank serves its devices until rank 0
// stops it.
#pragma once
#include <atomic>
#include <memory>
#include <thread>
#include <vector>
#include <string>

#include "render/engine/cluster.hpp"
#include "render/mpi/comm.hpp"
#include "render/mpi/mpi_executor.hpp"

namespace rayline::mpi {

class MpiCluster final : public engine::Cluster {
 public:
  // Collective: every rank constructs it (the LAN is measured here: rank 0 pings each rank).
  explicit MpiCluster(const Session& s);
  ~MpiCluster() override;
  int ranks() const override { return session_.size(); }
  int default_threads() const override;
  engine::LanModel lan() const override { return lan_; }
  void start(const engine::ClusterFrame& f) override;
  std::unique_ptr<engine::LocalExecutor> executor(const engine::ClusterWork& w) override;
  void finish(engine::RenderResult& res) override;
  std::vector<int> take_lost() override;
  // Fault injection (`--fail R2@1.5s`): rank `rank` kills itself (SIGKILL) `seconds` after it
  // got the frame, as a crashed machine would vanish. Every rank is told the same.
  void fail_at(int rank, double seconds) { fail_rank_ = rank, fail_at_ = seconds; }
  // A rank silent this long is taken as lost.
  static constexpr double kSilence = 3.0;
  // Ranks other than 0: serve until rank 0 sends Stop. Returns the process's exit code.
  int serve();

 private:
  void on_message(int source, Buffer m);  // rank 0's receiver thread
  void watch();                           // rank 0: finds silent ranks
  void lose(int rank);
  int live_ranks() const;
  const Session& session_;
  Comm comm_;
  engine::LanModel lan_;
  Pending pending_;
  ExecTime exec_time_{session_.size()};
  std::unique_ptr<Node> self_;
  std::mutex mu_;
  std::condition_variable cv_;
  int ready_ = 0;                    // ranks that answered Setup / Stop
  std::string fatal_;                // a rank's Fatal message
  std::vector<engine::RankStats> stats_;
  engine::ClusterFrame frame_;
  engine::LocalExecutor* executor_ = nullptr;
  std::vector<int> lost_, lost_new_;
  std::atomic<bool> stop_watch_{false};
  std::thread watchdog_;
  int fail_rank_ = -1;
  double fail_at_ = 0;
};

}  // namespace rayline::mpi
