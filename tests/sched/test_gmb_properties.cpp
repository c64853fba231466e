// Property tests over random platforms and job sets (acceptance):
//   no overlap on any timeline, no E-job before its inputs are resident, capacities never
//   exceeded, every job scheduled exactly once, makespan never below a lower bound —
//   with plans executed exactly, and with reality perturbed (reprojection + re-planning).
// Plus GMB against the exhaustive optimum on small instances (<= 7 jobs, <= 3 devices).
#include <gtest/gtest.h>

#include <cstdlib>
#include <functional>
#include <random>

#include "common/error.hpp"

#include "dcg_fixture.hpp"
#include "sched/runtime/exact_executor.hpp"
#include "sched/policy/gmb/gmb_scheduler.hpp"
#include "sched/runtime/runtime_loop.hpp"
#include "sched/runtime/fault.hpp"

using namespace rayline;
using rayline::testing::check_schedule;
using rayline::testing::DcgBuilder;
using rayline::testing::makespan;

namespace {
constexpr double MB = 1e6;

struct Instance {
  DeviceGraph g;
  JobPool pool;
  std::vector<std::pair<BlockId, MemId>> initial;
};

// Random cluster: 1-3 nodes, each with disk, ram, optional GPU memory; 1-3 CPU threads on
// ram, a GPU on GPU memory; SATA half duplex, PCIe full duplex, LAN through NIC resources.
Instance random_instance(std::mt19937& rng, bool tight_memory, bool with_dag) {
  std::uniform_int_distribution<int> nodes_d(1, 3), cpus_d(1, 3), coin(0, 1);
  std::uniform_real_distribution<double> bw(20 * MB, 400 * MB), lat(0, 0.01), rate(50 * MB, 500 * MB);
  DcgBuilder b;
  std::vector<MemId> disks, rams, all_exec_mems;
  const int n = nodes_d(rng);
  for (int i = 0; i < n; ++i) {
    const std::string p = "n" + std::to_string(i);
    const NodeId nd = b.node(p);
    const MemId disk = b.mem(p + ".disk", Bytes(1) << 40, MemoryKind::Disk, nd);
    const MemId ram = b.mem(p + ".ram", 0, MemoryKind::Host, nd);  // capacity set below
    disks.push_back(disk);
    rams.push_back(ram);
    b.half_duplex(disk, ram, bw(rng), lat(rng));
    for (int c = 0; c < cpus_d(rng); ++c) b.dev(p + ".cpu" + std::to_string(c), ram);
    all_exec_mems.push_back(ram);
    if (coin(rng)) {
      const MemId gm = b.mem(p + ".gpumem", 0, MemoryKind::Gpu, nd);
      b.full_duplex(ram, gm, bw(rng) * 10, lat(rng) / 10);
      b.dev(p + ".gpu", gm, ComputeKind::Gpu);
      all_exec_mems.push_back(gm);
    }
  }
  std::vector<ResourceId> nic_out, nic_in;
  for (int i = 0; i < n; ++i) {
    const double nbw = bw(rng);
    nic_out.push_back(b.resource("nic" + std::to_string(i) + ".out", nbw));
    nic_in.push_back(b.resource("nic" + std::to_string(i) + ".in", nbw));
  }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      if (i != j) {
        const double cbw = std::min(b.g.resources[nic_out[i]].bandwidth, b.g.resources[nic_in[j]].bandwidth);
        b.channel(rams[i], rams[j], cbw, 1e-4, {nic_out[i], nic_in[j]});
      }
  b.g.finalize();
  Instance inst;
  // Per-device rates differ (heterogeneity); GPUs faster.
  for (std::size_t d = 0; d < b.g.computes.size(); ++d)
    for (JobTypeId t = 0; t < 2; ++t) {
      auto& c = b.g.timing.at(static_cast<DeviceId>(d), t);
      c.supported = true;
      const double speed = b.g.computes[d].kind == ComputeKind::Gpu ? 10 : 1;
      c.setup = b.g.computes[d].kind == ComputeKind::Gpu ? 5e-5 : 5e-6;
      c.rate[static_cast<int>(DataKind::RayQueue)] = 1.0 / (rate(rng) * speed);
      c.rate[static_cast<int>(DataKind::SceneData)] = 1.0 / (rate(rng) * speed * 20);
      c.rate[static_cast<int>(DataKind::Generic)] = 1.0 / (rate(rng) * speed);
    }
  // Scene blocks on one or all disks, ray queues in random RAMs.
  std::uniform_int_distribution<int> nblocks_d(2, 8), njobs_d(4, 30);
  std::uniform_real_distribution<double> scene_mb(5, 200), queue_mb(0.5, 30);
  const int nb = nblocks_d(rng);
  std::vector<BlockId> scenes;
  Bytes max_need = 0;
  for (int i = 0; i < nb; ++i) {
    DataBlock blk;
    blk.name = "scene" + std::to_string(i);
    blk.kind = DataKind::SceneData;
    blk.bytes = static_cast<Bytes>(scene_mb(rng) * MB);
    const BlockId id = inst.pool.add_block(blk);
    scenes.push_back(id);
    if (coin(rng)) {
      for (MemId d : disks) inst.initial.emplace_back(id, d);
    } else {
      inst.initial.emplace_back(id, disks[std::uniform_int_distribution<int>(0, n - 1)(rng)]);
    }
  }
  const int nj = njobs_d(rng);
  std::vector<BlockId> produced;
  for (int i = 0; i < nj; ++i) {
    Job j;
    j.name = "j" + std::to_string(i);
    if (with_dag && !produced.empty() && coin(rng)) {
      // A job that consumes an earlier job's output (job-job dependency through data).
      j.type = 1;
      j.inputs = {produced[std::uniform_int_distribution<std::size_t>(0, produced.size() - 1)(rng)]};
      std::erase(produced, j.inputs[0]);
    } else {
      j.type = 0;
      DataBlock q;
      q.name = "rays" + std::to_string(i);
      q.kind = DataKind::RayQueue;
      q.consumed = true;
      q.bytes = static_cast<Bytes>(queue_mb(rng) * MB);
      const BlockId qb = inst.pool.add_block(q);
      const BlockId sb = scenes[std::uniform_int_distribution<std::size_t>(0, scenes.size() - 1)(rng)];
      q.scene_block = sb;
      inst.initial.emplace_back(qb, rams[std::uniform_int_distribution<int>(0, n - 1)(rng)]);
      j.inputs = {sb, qb};
      if (with_dag && coin(rng)) {
        DataBlock o;
        o.name = "out" + std::to_string(i);
        o.kind = DataKind::Generic;
        o.bytes = static_cast<Bytes>(queue_mb(rng) * MB);
        const BlockId ob = inst.pool.add_block(o);
        j.outputs = {ob};
        produced.push_back(ob);
      }
    }
    Bytes need = 0;
    for (BlockId x : j.inputs) need += inst.pool.block(x).bytes;
    for (BlockId x : j.outputs) need += inst.pool.block(x).bytes;
    max_need = std::max(max_need, need);
    inst.pool.add_job(std::move(j));
  }
  // RAM must hold the initial ray queues plus the biggest job; tight: barely more.
  std::vector<Bytes> initial_q(b.g.memories.size(), 0);
  for (auto [blk, m] : inst.initial)
    if (inst.pool.block(blk).kind == DataKind::RayQueue) initial_q[m] += inst.pool.block(blk).bytes;
  std::uniform_real_distribution<double> slack(tight_memory ? 1.05 : 3.0, tight_memory ? 1.6 : 10.0);
  for (MemId m : all_exec_mems) {
    const double base = static_cast<double>(initial_q[m] + 2 * max_need);
    b.g.memories[m].capacity = static_cast<Bytes>(base * slack(rng));
  }
  inst.g = b.g;
  inst.g.finalize();
  return inst;
}

// Lower bound: the longest single job on its best device, fetch of its initial inputs
// included (uncontended), and total work spread perfectly over all devices.
Time lower_bound(const DeviceGraph& g, const JobPool& pool, const std::vector<std::pair<BlockId, MemId>>& init) {
  Time lb_job = 0, total = 0;
  for (std::size_t j = 0; j < pool.job_count(); ++j) {
    const Job& job = pool.job(static_cast<JobId>(j));
    std::vector<InputSize> sizes;
    for (BlockId b : job.inputs) sizes.push_back({pool.block(b).kind, pool.block(b).bytes});
    Time best = kNever, best_exec = kNever;
    for (std::size_t d = 0; d < g.computes.size(); ++d) {
      if (!g.timing.supports(static_cast<DeviceId>(d), job.type)) continue;
      const Time ex = g.timing.exec_time(static_cast<DeviceId>(d), job.type, sizes);
      Time fetch = 0;
      bool from_initial = true;
      for (BlockId b : job.inputs) {
        if (pool.producer(b) != kNone) { from_initial = false; continue; }
        std::vector<MemId> src;
        for (auto [blk, m] : init) if (blk == b) src.push_back(m);
        fetch = std::max(fetch, g.shortest_fetch_times(src, pool.block(b).bytes)[g.computes[d].memory]);
      }
      best = std::min(best, (from_initial ? fetch : 0) + ex);
      best_exec = std::min(best_exec, ex);
    }
    lb_job = std::max(lb_job, best);
    total += best_exec;
  }
  return std::max(lb_job, total / static_cast<double>(g.computes.size()));
}

struct RunResult {
  Time makespan;
  bool stalled;
  int withdrawn = 0;
};

// All jobs known up front; whenever a job ends, it may withdraw another planned job's
// activities (Schedule::cancel_job) as the path-tracing workload does with failed
// predictions. Jobs with outputs are never withdrawn (nothing would make their outputs).
class WithdrawingWorkload final : public Workload {
 public:
  explicit WithdrawingWorkload(std::uint32_t seed) : rng_(seed) {}
  void start(Time, JobPool&, Schedule&) override {}
  void on_job_finished(JobId, Time, JobPool& pool, Schedule& s) override {
    if (std::uniform_int_distribution<int>(0, 1)(rng_) == 0) return;
    std::vector<JobId> planned;
    for (std::size_t j = 0; j < pool.job_count(); ++j) {
      const auto id = static_cast<JobId>(j);
      if (pool.state(id) == JobState::Planned && pool.job(id).outputs.empty() &&
          s.activity(pool.activity(id)).state == ActivityState::Planned && !s.activity(pool.activity(id)).cancelled)
        planned.push_back(id);
    }
    if (planned.empty()) return;
    const Schedule::CancelCount n =
        s.cancel_job(planned[std::uniform_int_distribution<std::size_t>(0, planned.size() - 1)(rng_)]);
    withdrawn += n.execs + n.transfers;
  }
  bool finished() const override { return true; }
  int withdrawn = 0;

 private:
  std::mt19937 rng_;
};

RunResult run(Instance& inst, Time horizon, const std::function<Time(ActivityId, const Activity&)>& perturb,
              bool completion_aware, bool withdraw = false, std::uint32_t seed = 0, const std::vector<Fault>& faults = {},
              RunStats* stats = nullptr) {
  Schedule s(inst.g, inst.pool);
  for (auto [b, m] : inst.initial) s.put_initial(b, m);
  GmbScheduler gmb({.horizon = horizon, .completion_aware = completion_aware});
  ExactExecutor ex(s);
  ex.perturb = perturb;
  StaticWorkload static_wl;
  WithdrawingWorkload withdrawing_wl(seed);
  Workload& wl = withdraw ? static_cast<Workload&>(withdrawing_wl) : static_wl;
  RuntimeLoop loop(gmb, ex, wl, inst.pool, s);
  for (const Fault& f : faults) loop.add_fault(f);
  const RunStats st = loop.run();
  if (stats) *stats = st;
  const auto check = check_schedule(s, inst.pool);
  // Nothing runs on a lost device after its fault: whatever ran there ended by then.
  for (const Fault& f : faults) {
    if (st.faults == 0) break;
    for (std::size_t i = 0; i < s.activity_count(); ++i) {
      const Activity& a = s.activity(static_cast<ActivityId>(i));
      if (a.state == ActivityState::Failed) continue;
      const bool lost = a.kind == ActivityKind::Exec ? !s.compute_alive(a.device) : !s.channel_alive(a.channel);
      if (lost && a.end > f.at + 1e-9) ADD_FAILURE() << "activity " << i << " ran on a lost device until " << a.end;
    }
  }

  for (const auto& e : check.errors) ADD_FAILURE() << e;
  for (std::size_t j = 0; j < inst.pool.job_count(); ++j)
    EXPECT_EQ(inst.pool.state(static_cast<JobId>(j)), JobState::Done) << inst.pool.job(static_cast<JobId>(j)).name;
  return {st.makespan, st.stalled, withdrawing_wl.withdrawn};
}
}  // namespace

class GmbProperty : public ::testing::TestWithParam<int> {};

TEST_P(GmbProperty, InvariantsHoldOnRandomInstances) {
  // 0: exact, ample memory; 1: tight memory; 2: DAG; 3: perturbed reality;
  // 4: completion-aware GMB with tight memory, DAG and perturbed reality;
  // 5: like 3, and planned jobs are withdrawn at random (Schedule::cancel_job, Sec. 5.2).
  const int mode = GetParam();
  int checked = 0, withdrawn = 0;
  double worst_gap = 1e9;
  for (int seed = 0; seed < 60; ++seed) {
    std::mt19937 rng(1000 * mode + seed);
    Instance inst = random_instance(rng, mode == 1 || mode >= 3, mode >= 2);
    const Time lb = lower_bound(inst.g, inst.pool, inst.initial);
    const Time horizon = std::array<Time, 3>{0.05, 2.0, 1e9}[seed % 3];
    std::function<Time(ActivityId, const Activity&)> perturb;
    if (mode >= 3) {
      auto prng = std::make_shared<std::mt19937>(seed);
      perturb = [prng](ActivityId, const Activity& a) {
        return a.duration * std::uniform_real_distribution<double>(0.6, 1.6)(*prng);
      };
    }
    const RunResult r = run(inst, horizon, perturb, mode == 4, mode == 5, static_cast<std::uint32_t>(seed));
    withdrawn += r.withdrawn;
    ASSERT_FALSE(r.stalled) << "seed " << seed;
    if (mode < 3) {
      EXPECT_GE(r.makespan, lb * (1 - 1e-9)) << "seed " << seed;
      worst_gap = std::min(worst_gap, r.makespan / lb);
    }
    ++checked;
    if (HasFailure()) {
      ADD_FAILURE() << "first failing seed " << seed << " mode " << mode;
      return;
    }
  }
  if (mode == 5) {
    EXPECT_GT(withdrawn, 100) << "the withdrawing runs must actually withdraw activities";
    std::printf("[property mode 5] %d random instances, %d activities withdrawn, invariants hold\n", checked, withdrawn);
  } else if (mode < 3) std::printf("[property mode %d] %d random instances, min makespan/lower-bound %.3f\n", mode, checked, worst_gap);
  else std::printf("[property mode %d] %d random instances, invariants hold under perturbed durations\n", mode, checked);
}

INSTANTIATE_TEST_SUITE_P(Modes, GmbProperty, ::testing::Values(0, 1, 2, 3, 4, 5));

// Instances a soak of 6 000 seeds per mode found, kept as regressions:
//   * modes 3 and 4: memory over capacity once reality ran late. Room that a leaving ray
//     queue or an evicted copy freed beyond what the incoming block needed was free at
//     once, so a later fetch counted on it without waiting for the activities that free it;
//   * mode 5: a T-job withdrawn although the E-job reading its copy still needed it, because
//     that copy had been evicted (Schedule::cancel took an evicted copy for an unused one).
TEST(GmbProperty, SoakFoundInstancesStayRegressions) {
  struct Case { int mode, seed; };
  for (const Case c : {Case{3, 2565}, Case{4, 494}, Case{5, 46}}) {
    std::mt19937 rng(10000000u * static_cast<unsigned>(c.mode + 1) + static_cast<unsigned>(c.seed));
    Instance inst = random_instance(rng, true, c.mode >= 2);
    const Time horizon = std::array<Time, 3>{0.05, 2.0, 1e9}[c.seed % 3];
    auto prng = std::make_shared<std::mt19937>(c.seed);
    const std::function<Time(ActivityId, const Activity&)> perturb = [prng](ActivityId, const Activity& a) {
      return a.duration * std::uniform_real_distribution<double>(0.6, 1.6)(*prng);
    };
    const RunResult r = run(inst, horizon, perturb, c.mode == 4, c.mode == 5, static_cast<std::uint32_t>(c.seed));
    EXPECT_FALSE(r.stalled) << "mode " << c.mode << " seed " << c.seed;
    if (HasFailure()) {
      ADD_FAILURE() << "mode " << c.mode << " seed " << c.seed;
      return;
    }
  }
}

// A horizon k below the resolution of the clock (now + k == now once now > 0) still gives
// every device that runs dry a job (Sec. 4.2 re-plans when one does): the run never
// stalls, every job is done, and the invariants hold. GMB used to plan nothing then and
// report queued jobs as unplaceable.
TEST(GmbHorizon, BelowTheClockResolutionStillPlansEveryDryDevice) {
  for (int seed = 0; seed < 30; ++seed) {
    std::mt19937 rng(5000 + seed);
    Instance inst = random_instance(rng, seed % 2 == 0, seed % 3 == 0);
    std::function<Time(ActivityId, const Activity&)> perturb;
    if (seed % 4 == 1) {
      auto prng = std::make_shared<std::mt19937>(seed);
      perturb = [prng](ActivityId, const Activity& a) {
        return a.duration * std::uniform_real_distribution<double>(0.6, 1.6)(*prng);
      };
    }
    const Time lb = lower_bound(inst.g, inst.pool, inst.initial);
    const RunResult r = run(inst, 1e-300, perturb, seed % 5 == 2);
    ASSERT_FALSE(r.stalled) << "seed " << seed;
    if (!perturb) {
      EXPECT_GE(r.makespan, lb * (1 - 1e-9)) << "seed " << seed;
    }
    if (HasFailure()) return;
  }
}

// A plan executed with no perturbation reproduces the predicted makespan exactly when it
// was planned in one pass (k = infinity).
TEST(GmbExecution, PlanRunsExactlyAsPredicted) {
  for (int seed = 0; seed < 40; ++seed) {
    std::mt19937 rng(77 + seed);
    Instance inst = random_instance(rng, seed % 2 == 0, true);
    Schedule s(inst.g, inst.pool);
    for (auto [b, m] : inst.initial) s.put_initial(b, m);
    GmbScheduler gmb({.horizon = 1e12});
    // Plan everything up front (jobs whose inputs are produced by others wait for them).
    PlanStats ps = gmb.plan(0, inst.pool, s);
    ASSERT_EQ(inst.pool.queued_count(), 0u) << "seed " << seed;
    const Time predicted = makespan(s);
    ExactExecutor ex(s);
    for (std::size_t i = 0; i < s.activity_count(); ++i) ex.dispatch(static_cast<ActivityId>(i), s.activity(static_cast<ActivityId>(i)));
    std::vector<ExecutorEvent> ev;
    Time last = 0;
    while (ex.advance(ev)) {
      for (auto& e : ev) last = std::max(last, e.time);
      ev.clear();
    }
    EXPECT_DOUBLE_EQ(last, predicted) << "seed " << seed;
    (void)ps;
  }
}

// Exhaustive reference: every order of the jobs and every device for each, each placed
// with the same mechanics (Placer: SDC paths, earliest start after the device is free).
namespace {
struct Exhaustive {
  const DeviceGraph* g;
  Time best = kNever;
  void search(const JobPool& pool, const Schedule& s, Time current) {
    if (current >= best) return;  // branch and bound on the partial makespan
    if (pool.queued_count() == 0) {
      best = current;
      return;
    }
    const std::vector<JobId> q(pool.queued().begin(), pool.queued().end());
    for (JobId j : q)
      for (std::size_t d = 0; d < g->computes.size(); ++d) {
        if (!g->timing.supports(static_cast<DeviceId>(d), pool.job(j).type)) continue;
        JobPool p2 = pool;
        Schedule s2 = s;
        s2.rebind(p2);
        Placer placer(s2);
        PlanStats st;
        if (!placer.place(j, static_cast<DeviceId>(d), s2.device_timeline(static_cast<DeviceId>(d)).busy_until, 0, p2, s2, st)) continue;
        search(p2, s2, std::max(current, makespan(s2)));
      }
  }
};
}  // namespace

TEST(GmbExhaustive, WithinReportedRatioOfOptimumOnSmallInstances) {
  std::vector<double> ratios, ratios_ca;
  for (int seed = 0; seed < 40; ++seed) {
    std::mt19937 rng(5000 + seed);
    const int devices = 2 + seed % 2;                       // 2 or 3 devices
    const int jobs = devices == 2 ? 3 + seed % 5 : 3 + seed % 3;  // up to 7 jobs on 2, 5 on 3
    DcgBuilder b;
    std::uniform_real_distribution<double> bw(20 * MB, 200 * MB), rate(20 * MB, 200 * MB), size(5, 100);
    std::vector<MemId> mems;
    for (int i = 0; i < devices; ++i) {
      mems.push_back(b.mem("m" + std::to_string(i)));
      b.dev("d" + std::to_string(i), mems.back());
    }
    for (int i = 0; i < devices; ++i)
      for (int k = 0; k < devices; ++k)
        if (i != k) b.channel(mems[i], mems[k], bw(rng), 0.001);
    b.g.finalize();
    for (int d = 0; d < devices; ++d) {
      auto& c = b.g.timing.at(d, 0);
      c.supported = true;
      c.setup = 0.01;
      c.rate[static_cast<int>(DataKind::SceneData)] = 1.0 / rate(rng);
    }
    DeviceGraph g = b.build();
    JobPool pool;
    std::vector<std::pair<BlockId, MemId>> init;
    const int nblocks = std::max(1, jobs - 1);
    for (int i = 0; i < nblocks; ++i) {
      DataBlock blk;
      blk.name = "b" + std::to_string(i);
      blk.kind = DataKind::SceneData;
      blk.bytes = static_cast<Bytes>(size(rng) * MB);
      init.emplace_back(pool.add_block(blk), mems[std::uniform_int_distribution<int>(0, devices - 1)(rng)]);
    }
    for (int i = 0; i < jobs; ++i) {
      Job j;
      j.name = "j" + std::to_string(i);
      j.type = 0;
      j.inputs = {static_cast<BlockId>(std::uniform_int_distribution<int>(0, nblocks - 1)(rng))};
      pool.add_job(std::move(j));
    }
    JobPool pool_gmb = pool;
    Schedule s(g, pool_gmb);
    for (auto [bb, m] : init) s.put_initial(bb, m);
    GmbScheduler gmb({.horizon = 1e12});
    gmb.plan(0, pool_gmb, s);
    const Time gmb_ms = makespan(s);
    JobPool pool_ca = pool;
    Schedule sca(g, pool_ca);
    for (auto [bb, m] : init) sca.put_initial(bb, m);
    GmbScheduler gmb_ca({.horizon = 1e12, .completion_aware = true});
    gmb_ca.plan(0, pool_ca, sca);
    const Time ca_ms = makespan(sca);
    Schedule s0(g, pool);
    for (auto [bb, m] : init) s0.put_initial(bb, m);
    Exhaustive ex{&g};
    ex.search(pool, s0, 0);
    ASSERT_LT(ex.best, kNever);
    EXPECT_GE(gmb_ms, ex.best * (1 - 1e-9)) << "the exhaustive optimum must not be worse than GMB";
    EXPECT_GE(ca_ms, ex.best * (1 - 1e-9));
    ratios.push_back(gmb_ms / ex.best);
    ratios_ca.push_back(ca_ms / ex.best);
    if (std::getenv("RAYLINE_DEBUG_EXHAUSTIVE") && gmb_ms / ex.best > 1.5) {
      std::printf("seed %d: gmb %.3f opt %.3f\n", seed, gmb_ms, ex.best);
      for (std::size_t i = 0; i < s.activity_count(); ++i) {
        const Activity& a = s.activity(static_cast<ActivityId>(i));
        std::printf("  %s job %d dev %d ch %d block %d  [%.3f, %.3f]\n", a.kind == ActivityKind::Exec ? "E" : "T", a.job,
                    a.device, a.channel, a.block, a.start, a.end);
      }
      for (auto [bb, m] : init) std::printf("  block %d at m%d (%.0f MB)\n", bb, m, pool.block(bb).bytes / MB);
      for (int d = 0; d < devices; ++d) std::printf("  d%d rate %.1f MB/s\n", d, 1 / g.timing.at(d, 0).rate[0] / MB);
    }
  }
  auto stats = [](const std::vector<double>& v) {
    double worst = 0, mean = 0;
    for (double r : v) {
      worst = std::max(worst, r);
      mean += r / static_cast<double>(v.size());
    }
    return std::make_pair(mean, worst);
  };
  const auto [mean, worst] = stats(ratios);
  const auto [mean_ca, worst_ca] = stats(ratios_ca);
  std::printf("[exhaustive] %zu instances (2-3 devices, 3-7 jobs): GMB/optimum mean %.4f, worst %.4f; "
              "completion-aware GMB mean %.4f, worst %.4f\n",
              ratios.size(), mean, worst, mean_ca, worst_ca);
  RecordProperty("gmb_over_optimum_mean", std::to_string(mean));
  RecordProperty("gmb_over_optimum_worst", std::to_string(worst));
  // Regression guard at the level measured when this test was written (mean 1.25, worst
  // 3.11): GMB picks the least-loaded device first (Sec. 4.2), so a slow device, or one
  // that must fetch, may take a job another device would finish much sooner.
  EXPECT_LT(mean, 1.35);
  EXPECT_LT(worst, 3.5);
  // The completion-aware refinement must keep its measured edge (mean 1.16, worst 2.12).
  EXPECT_LT(mean_ca, mean);
  EXPECT_LT(worst_ca, 2.5);
}

// Faults (docs/faults.md): compute devices lost mid-run, at random times, on random
// instances with tight memory, DAGs and perturbed reality. The run re-plans the aborted
// work on the devices left and completes: every job done by exactly one E-job, the plan
// invariants hold, and nothing runs on a lost device after its fault.
TEST(GmbFaults, ComputeDevicesLostMidRunEveryJobStillDoneOnce) {
  std::uint64_t aborted = 0, requeued = 0, start_requeued = 0;
  int applied = 0;
  for (int seed = 0; seed < 60; ++seed) {
    std::mt19937 rng(7000 + seed);
    const Instance base = random_instance(rng, seed % 2 == 0, seed % 3 == 0);
    if (base.g.computes.size() < 2) continue;
    std::function<Time(ActivityId, const Activity&)> perturb;
    if (seed % 4 == 1) {
      auto prng = std::make_shared<std::mt19937>(seed);
      perturb = [prng](ActivityId, const Activity& a) {
        return a.duration * std::uniform_real_distribution<double>(0.6, 1.6)(*prng);
      };
    }
    const Time horizon = std::array<Time, 3>{0.05, 2.0, 1e9}[seed % 3];
    Instance clean = base;
    const Time m0 = run(clean, horizon, nullptr, false).makespan;
    Fault f;
    // Every sixth at the start: between the first plan and its dispatch.
    f.at = seed % 6 == 5 ? 0.0 : m0 * std::uniform_real_distribution<double>(0.05, 0.8)(rng);
    std::vector<DeviceId> all(base.g.computes.size());
    for (std::size_t d = 0; d < all.size(); ++d) all[d] = static_cast<DeviceId>(d);
    std::shuffle(all.begin(), all.end(), rng);
    const std::size_t n_lost = std::min<std::size_t>(all.size() - 1, 1 + seed % 2);
    f.computes.assign(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(n_lost));
    f.what = "seed " + std::to_string(seed);
    Instance inst = base;
    RunStats st;
    const RunResult r = run(inst, horizon, perturb, seed % 5 == 2, false, 0, {f}, &st);
    ASSERT_FALSE(r.stalled) << "seed " << seed;
    applied += st.faults;
    aborted += st.aborted;
    requeued += st.requeued;
    if (f.at == 0.0) start_requeued += st.requeued;
    if (HasFailure()) {
      ADD_FAILURE() << "first failing seed " << seed;
      return;
    }
  }
  EXPECT_GT(applied, 40);
  EXPECT_GT(requeued, 20u) << "the faults must actually hit planned work";
  EXPECT_GT(start_requeued, 0u) << "a fault at 0 s must take back the first plan's work on the lost devices";
  std::printf("[faults] %d faults applied, %llu activities aborted, %llu jobs queued again; every job done once\n",
              applied, static_cast<unsigned long long>(aborted), static_cast<unsigned long long>(requeued));
}

// A whole node lost (its memories with their data): a job whose ray queue had its only
// copy there cannot be recovered by a static job set, and the run ends with an error that
// says so; otherwise (the data was elsewhere, or already used) the run completes.
TEST(GmbFaults, NodeLostEitherCompletesOrNamesTheLostData) {
  int completed = 0, lost = 0;
  for (int seed = 0; seed < 60; ++seed) {
    std::mt19937 rng(9000 + seed);
    const Instance base = random_instance(rng, false, seed % 3 == 0);
    if (base.g.nodes.size() < 2) continue;
    Instance clean = base;
    const Time m0 = run(clean, 2.0, nullptr, false).makespan;
    Fault f;
    f.at = m0 * std::uniform_real_distribution<double>(0.05, 0.9)(rng);
    // (DcgBuilder leaves Node's lists empty: the devices name their node.)
    const auto node = static_cast<NodeId>(std::uniform_int_distribution<std::size_t>(0, base.g.nodes.size() - 1)(rng));
    for (std::size_t m = 0; m < base.g.memories.size(); ++m)
      if (base.g.memories[m].node == node) f.memories.push_back(static_cast<MemId>(m));
    for (std::size_t d = 0; d < base.g.computes.size(); ++d)
      if (base.g.computes[d].node == node) f.computes.push_back(static_cast<DeviceId>(d));
    Instance inst = base;
    try {
      RunStats st;
      const RunResult r = run(inst, 2.0, nullptr, false, false, 0, {f}, &st);
      EXPECT_FALSE(r.stalled) << "seed " << seed;
      ++completed;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("no other copy"), std::string::npos) << e.what();
      ++lost;
    }
    if (HasFailure()) {
      ADD_FAILURE() << "first failing seed " << seed;
      return;
    }
  }
  EXPECT_GT(completed, 0);
  EXPECT_GT(lost, 0);
  std::printf("[faults] node lost: %d runs completed, %d ended naming lost data\n", completed, lost);
}

TEST(GmbFaults, ParsesDeviceAtTime) {
  const Instance inst = [] {
    std::mt19937 rng(3);
    return random_instance(rng, false, false);
  }();
  const Fault n = parse_fault("n0@1.5s", inst.g);
  EXPECT_DOUBLE_EQ(n.at, 1.5);
  EXPECT_EQ(n.memories, inst.g.nodes[0].memories);
  EXPECT_EQ(n.computes, inst.g.nodes[0].computes);
  const Fault c = parse_fault("n0.cpu0@250ms", inst.g);
  EXPECT_DOUBLE_EQ(c.at, 0.25);
  ASSERT_EQ(c.computes.size(), 1u);
  EXPECT_TRUE(c.memories.empty());
  for (const char* bad : {"n0", "@1s", "n0@", "n0@5", "nowhere@1s", "n0@-1s"}) {
    try {
      parse_fault(bad, inst.g);
      ADD_FAILURE() << bad << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("--fail"), std::string::npos) << e.what();
    }
  }
}
