// Placer: commits one E-job on one compute device together with the T-jobs that fetch its
// missing inputs along SDC paths (Sec. 4.4), applying capacity admission (evictions) on
// every hop. GMB decides *what* goes *where*; the Placer does the committing, so every
// scheduler (GMB, the baselines, the exhaustive reference in the tests) builds schedules
// with the same mechanics.
#pragma once
#include <vector>

#include "sched/sdc/fetch_path.hpp"
#include "sched/policy/scheduler.hpp"

namespace rayline {

class Placer {
 public:
  explicit Placer(const Schedule& s) : finder_(s) {}
  FetchPathFinder& finder() { return finder_; }
  // Plan on another Schedule of the same platform, keeping the buffers.
  void rebind(const Schedule& s) { finder_.rebind(s); }

  // Sec. 5.1: framebuffers move only for AdditiveCompose; every other block may be fetched.
  static bool may_fetch(const Job& j, BlockId b, const Schedule& s) {
    return s.pool().block(b).kind != DataKind::Framebuffer || may_fetch_framebuffer(j, s);
  }
  static bool may_fetch_framebuffer(const Job& j, const Schedule& s);

  // Eq. 2 for j on d with its inputs' current sizes (0 when it has no bytes to process).
  static Time exec_estimate(JobId j, DeviceId d, const Schedule& s);

  // Earliest time job j could start on d if the device is free from `ready` (kNever if an
  // input cannot reach d's memory device or a job it follows is not planned). A job of many
  // inputs searches only those that can arrive last (placer.cpp).
  Time earliest_start(JobId j, DeviceId d, Time ready, const Schedule& s);

  // Commit j on d (T-jobs first, then the E-job not before `ready`). False when capacity
  // makes it impossible (nothing is committed then, except in the rare case documented in
  // place()). Transfers start no earlier than `now`.
  bool place(JobId j, DeviceId d, Time ready, Time now, JobPool& pool, Schedule& s, PlanStats& st);

 private:
  FetchPathFinder finder_;
  std::vector<ChannelId> path_;
  std::vector<ChannelId> paths_;      // place(): the feasibility pass's paths, concatenated
  std::vector<std::size_t> path_end_;
  // earliest_start(): the movable inputs with one copy elsewhere, for their Pareto front.
  struct OneCopyInput {
    MemId from;
    DataKind kind;
    Time ready;
    Bytes bytes;
    BlockId block;
  };
  std::vector<OneCopyInput> one_copy_, rest_;
  std::vector<std::pair<MemId, DataKind>> groups_;  // earliest_start's (memory device, kind) groups
};

}  // namespace rayline
