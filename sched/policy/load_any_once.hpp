// LoadAnyOnce (Navratil et al. 2014), the paper's second baseline (Sec. 6), faithful to
// GraviT's LoadAnyOnceSchedule as read in docs/baselines.md (Sec. 2.3):
//   * bulk-synchronous rounds: a round is planned only when every rank is idle;
//   * per-domain demand = queued rays summed over all ranks (rays that exist: a job whose
//     `after` predecessors are not all planned, or whose input is not produced yet, waits
//     for a later round instead of being committed before what it follows);
//   * domains sorted by demand (ties: higher domain id first, as GraviT's
//     (count << 7) + id key popped from the back), the i-th goes to rank i, each domain
//     to at most one rank ("Once"); ranks beyond the demanded domains stay idle (GraviT's
//     ranks all trace anything; here a domain skips a rank that can run none of its jobs,
//     such as a client node's thread, and goes to the next);
//   * the rank drains the whole domain: every queued job of that domain runs on it, and
//     whole ray queues are sent there;
//   * scene data is loaded from storage, never sent between ranks (SEND_DOMS is compiled
//     out): a block comes from a disk or from a copy already on the rank's own node.
// Variant: GraviT original. Ranks are compute devices; the paper's GPU adaptation
// ("additional worker processes that share GPU ownership round robin") is reduced to one
// rank per GPU — stated, not hidden. Domains are SceneData blocks (a job's key input).
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "sched/policy/placer.hpp"
#include "sched/policy/scheduler.hpp"

namespace rayline {

// The decision rule: rank -> index into `demand` (kNone: idle). Zero demand is never
// assigned. Pure, for unit tests.
std::vector<std::int32_t> load_any_once_assign(const std::vector<std::uint64_t>& demand, int ranks);
// The same on ranks that cannot all run every domain (a client node's thread that only
// composes frames): each domain, in the same order, goes to the first rank still free that
// `can` run it. With every rank able, the plain rule's map.
std::vector<std::int32_t> load_any_once_assign(const std::vector<std::uint64_t>& demand, int ranks,
                                               const std::function<bool(int rank, std::int32_t domain)>& can);

class LoadAnyOnceScheduler final : public Scheduler {
 public:
  std::string name() const override { return "loadanyonce"; }
  std::string describe() const override {
    return "loadanyonce{GraviT original: BSP rounds; one domain per rank; scene from own node or storage; one rank per device}";
  }
  PlanStats plan(Time now, JobPool& pool, Schedule& schedule) override;
  std::uint64_t rounds() const { return rounds_; }

 private:
  const Schedule* bound_ = nullptr;
  std::unique_ptr<Placer> placer_;
  std::uint64_t rounds_ = 0;
};

}  // namespace rayline
