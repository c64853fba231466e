// Hierarchical planning for large clusters (Rayline's extension of Sec. 4.2; planning
// speed at scale, docs/scheduler.md "Plan cells"). GMB as the paper describes it asks,
// for every idle device, which queued job of the whole cluster could start there
// earliest: its cost per placement grows with the node count. Here a cluster of more
// than `cell_nodes` nodes is cut into *cells* of at most `cell_nodes` consecutive nodes
// of one rack (a cell never spans two racks) and planning has two levels:
//   * the cluster level (assign()) gives every queued job a home cell: the cell already
//     holding its least-replicated input (a ray queue's memory; a producer's device for
//     an input not made yet), then moves jobs from cells with the most queued work per
//     device to cells that would run dry within the horizon k, smallest data first;
//   * the cell level is GMB itself, unchanged, except that a device considers only the
//     jobs homed in its cell (and jobs homed nowhere: no device of their cell runs them).
// With one cell (every platform of at most `cell_nodes` nodes, the paper's included)
// every job is eligible everywhere and the plans are GMB's, bit for bit.
#pragma once
#include <cstdint>
#include <vector>

#include "sched/core/job_pool.hpp"
#include "sched/timeline/schedule.hpp"

namespace rayline {

class PlanCells {
 public:
  // Cells of at most cell_nodes nodes (<= 0: one cell, the flat plan).
  void build(const DeviceGraph& g, int cell_nodes);
  int count() const { return n_cells_; }
  bool flat() const { return n_cells_ <= 1; }
  std::int32_t cell_of_memory(MemId m) const { return cell_of_mem_[static_cast<std::size_t>(m)]; }
  const std::vector<MemId>& memories(std::int32_t c) const { return mems_of_cell_[static_cast<std::size_t>(c)]; }
  // The cluster-level pass of one plan: a home for every queued job (kNone: any cell).
  void assign(Time now, Time horizon, const JobPool& pool, const Schedule& s);
  std::int32_t home(JobId j) const {
    return static_cast<std::size_t>(j) < home_.size() ? home_[static_cast<std::size_t>(j)] : kNone;
  }
  // May job j (queued) be planned on memory device m's devices?
  bool eligible(JobId j, MemId m) const {
    if (n_cells_ <= 1) return true;
    const std::int32_t h = home(j);
    return h == kNone || h == cell_of_mem_[static_cast<std::size_t>(m)];
  }
  std::uint64_t moved() const { return moved_; }  // jobs the last assign() moved off their data's cell

 private:
  std::int32_t locus_cell(const Job& job, const JobPool& pool, const Schedule& s) const;
  int n_cells_ = 1;
  std::vector<std::int32_t> cell_of_mem_;
  std::vector<std::vector<MemId>> mems_of_cell_;
  std::vector<std::vector<DeviceId>> devices_of_cell_;
  std::vector<std::uint64_t> types_of_cell_;  // bit t: some device of the cell runs job type t (types < 64)
  std::vector<std::int32_t> home_;            // per job id
  std::vector<JobId> homed_;                  // jobs with home_ set this pass
  std::uint64_t moved_ = 0;
};

}  // namespace rayline
