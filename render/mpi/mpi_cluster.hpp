// `rayline render --distributed` under mpirun (render/mpi/README.md): rank 0 renders with
// an MpiCluster as RenderOptions::cluster; every other rank serves its devices until rank 0
// stops it.
#pragma once
#include <memory>
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
  // Ranks other than 0: serve until rank 0 sends Stop. Returns the process's exit code.
  int serve();

 private:
  void on_message(int source, Buffer m);  // rank 0's receiver thread
  const Session& session_;
  Comm comm_;
  engine::LanModel lan_;
  Pending pending_;
  std::unique_ptr<Node> self_;
  std::mutex mu_;
  std::condition_variable cv_;
  int ready_ = 0;                    // ranks that answered Setup / Stop
  std::string fatal_;                // a rank's Fatal message
  std::vector<engine::RankStats> stats_;
  engine::ClusterFrame frame_;
  engine::BlockStore* store_ = nullptr;
};

}  // namespace rayline::mpi
