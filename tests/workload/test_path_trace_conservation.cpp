// The path-tracing workload under GMB and the exact executor, on the paper's two-node
// platform: over whole frames, every ray created (primary, secondary, shadow) ends exactly
// once (hit, escaped, occluded, lit), and every delivered frame has exactly spp samples
// per pixel (summed over the partial framebuffers composed at the client: per tile under
// replay, per frame where counts carry no tile) — for
// every fidelity level, with job prediction off and on. Replay reproduces a recorded run's
// per-job ray counts exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <functional>
#include <memory>
#include <random>
#include <set>
#include <sstream>

#include "common/error.hpp"
#include "sched/runtime/exact_executor.hpp"
#include "sched/policy/gmb/gmb_scheduler.hpp"
#include "sched/policy/placer.hpp"
#include "sched/policy/rayline/rayline_scheduler.hpp"
#include "sched/policy/scheduler_factory.hpp"
#include "workload/path_trace_workload.hpp"
#include "sched/io/platform_loader.hpp"
#include "sched/runtime/runtime_loop.hpp"
#include "sched/runtime/fault.hpp"
#include "workload/scene_profile.hpp"

using namespace rayline;

namespace {

const std::string kProfile = std::string(RAYLINE_TEST_DATA) + "/profiles/small.profile.json";

struct Outcome {
  RayTally tally;
  std::vector<FrameReport> frames;
  std::vector<std::uint64_t> job_rays;  // per job id
  std::vector<int> job_types;
  PredictionStats prediction;
  std::uint64_t alive = 0, fallback = 0, exact_pieces = 0;
  bool stalled = false;
  std::uint64_t merges_into_planned = 0;
  Schedule::CancelCount withdrawn;
};

using Inspect = std::function<void(const DeviceGraph&, const JobPool&, const Schedule&, const PathTraceWorkload&)>;

Outcome run(Fidelity fid, int depth, std::shared_ptr<ReplayLog> replay = nullptr, ReplayLog* record = nullptr,
        int clients = 2, int frames = 2, std::uint64_t seed = 7, bool merge_planned = true, bool cancel_failed = true,
        bool retime_merged = true, const Inspect& inspect = {}, const std::string& scheduler = "gmb",
        Bytes host_capacity = 0, Bytes gpu_capacity = 0, const std::vector<Bytes>* job_caps_override = nullptr,
        bool ray_origins = false, const std::function<NodeId(std::uint64_t, BlockId)>& origin = {}) {
  DeviceGraph g = load_platform(std::string(RAYLINE_PLATFORMS) + "/paper-2A.json");
  for (MemoryDevice& m : g.memories) {  // smaller memories: a scene that no node holds alone
    if (m.kind == MemoryKind::Host && host_capacity > 0) m.capacity = host_capacity;
    if (m.kind == MemoryKind::Gpu && gpu_capacity > 0) m.capacity = gpu_capacity;
  }
  const SceneProfile prof = load_scene_profile(kProfile);
  PathTraceOptions o;
  o.clients = clients;
  o.frames_per_client = frames;
  o.prediction_depth = depth;
  o.fidelity = fid;
  o.replay = std::move(replay);
  o.record = record;
  o.seed = seed;
  o.merge_planned = merge_planned;
  o.cancel_failed = cancel_failed;
  o.retime_merged = retime_merged;
  // The policy's device-sized jobs, as `rayline simulate` sets them (sim/simulation.cpp).
  o.job_bytes_cap = job_caps_override ? *job_caps_override : job_caps(SchedulerChoice{.kind = *scheduler_kind(scheduler)}, g);
  JobPool pool;
  Schedule s(g, pool);
  PathTraceWorkload wl(g, prof, o);
  // Rayline's rule 8 switched on, wired as `rayline simulate --rayline-on generation` does.
  const std::unique_ptr<Scheduler> sched =
      ray_origins ? std::make_unique<RaylineScheduler>(rayline_options(0.5, 0, rayline_rule_bit("generation")))
                  : make_scheduler(scheduler, 2.0);
  if (sched->places_ray_origins())
    wl.set_ray_origin([&](std::uint64_t wave, BlockId entry) { return sched->ray_origin(wave, entry, pool, s); });
  if (origin) wl.set_ray_origin(origin);
  ExactExecutor ex(s);
  RuntimeLoop loop(*sched, ex, wl, pool, s);
  const RunStats st = loop.run();
  if (inspect) inspect(g, pool, s, wl);
  Outcome r;
  r.tally = wl.tally();
  r.frames = wl.frames();
  for (std::size_t j = 0; j < pool.job_count(); ++j) {
    r.job_rays.push_back(wl.job_rays(static_cast<JobId>(j)));
    r.job_types.push_back(pool.job(static_cast<JobId>(j)).type);
  }
  if (wl.prediction()) r.prediction = *wl.prediction();
  r.alive = wl.rays_alive();
  r.fallback = wl.model().fallback_rays();
  r.exact_pieces = wl.model().exact_pieces();
  r.stalled = st.stalled;
  r.merges_into_planned = wl.merges_into_planned();
  r.withdrawn = wl.withdrawn();
  // Withdrawn predictions leave no trace a live activity reads (docs/architecture.md invariants).
  std::size_t cancelled = 0;
  for (std::size_t i = 0; i < s.activity_count(); ++i) {
    const Activity& a = s.activity(static_cast<ActivityId>(i));
    if (!a.cancelled) continue;
    ++cancelled;
    EXPECT_EQ(a.state, ActivityState::Done);
    EXPECT_EQ(a.end, a.start) << "a withdrawn activity runs for 0 s";
  }
  EXPECT_EQ(cancelled, static_cast<std::size_t>(r.withdrawn.execs + r.withdrawn.transfers));
  return r;
}

void expect_conserved(const Outcome& r, int clients, int frames) {
  EXPECT_FALSE(r.stalled);
  EXPECT_GT(r.tally.primary, 0u);
  EXPECT_GT(r.tally.secondary, 0u);
  EXPECT_GT(r.tally.shadow, 0u);
  EXPECT_EQ(r.tally.created(), r.tally.ended());
  EXPECT_EQ(r.alive, 0u);
  ASSERT_EQ(r.frames.size(), static_cast<std::size_t>(clients * frames));
  for (const FrameReport& f : r.frames) EXPECT_TRUE(f.exact) << "client " << f.client << " frame " << f.index;
  // 64 x 48 pixels x 2 spp per frame.
  EXPECT_EQ(r.tally.primary, static_cast<std::uint64_t>(64 * 48 * 2 * clients * frames));
}

std::shared_ptr<ReplayLog> recorded(Outcome* out = nullptr, int depth = 0) {
  auto log = std::make_shared<ReplayLog>();
  Outcome r = run(Fidelity::Markov, depth, nullptr, log.get());
  if (out) *out = r;
  return log;
}

}  // namespace

TEST(PathTraceConservation, AnalyticNoPrediction) { expect_conserved(run(Fidelity::Analytic, 0), 2, 2); }
TEST(PathTraceConservation, AnalyticPrediction) { expect_conserved(run(Fidelity::Analytic, 2), 2, 2); }
TEST(PathTraceConservation, MarkovNoPrediction) { expect_conserved(run(Fidelity::Markov, 0), 2, 2); }
TEST(PathTraceConservation, MarkovPrediction) {
  const Outcome r = run(Fidelity::Markov, 3);
  expect_conserved(r, 2, 2);
  EXPECT_GT(r.prediction.created, 0u);
  EXPECT_GT(r.prediction.confirmed, 0u);
  EXPECT_GT(r.withdrawn.execs, 0) << "failed planned predictions are withdrawn (Sec. 5.2)";
  EXPECT_GE(r.prediction.accuracy(), 0.0);
  EXPECT_LE(r.prediction.accuracy(), 1.0);
}
TEST(PathTraceConservation, MarkovPredictionWithoutWithdrawing) {
  const Outcome r = run(Fidelity::Markov, 2, nullptr, nullptr, 2, 2, 7, true, false);
  expect_conserved(r, 2, 2);
  EXPECT_EQ(r.withdrawn.execs + r.withdrawn.transfers, 0);
}

TEST(PathTraceConservation, ReplayNoPrediction) {
  expect_conserved(run(Fidelity::Replay, 0, recorded()), 2, 2);
}
TEST(PathTraceConservation, ReplayPrediction) {
  // Recorded without prediction, replayed with: the batching differs, the per-context
  // totals of the recording are still handed out exactly.
  const Outcome r = run(Fidelity::Replay, 2, recorded());
  expect_conserved(r, 2, 2);
  EXPECT_EQ(r.fallback, 0u);
}

// --merge-planned off: arriving rays never join a planned job (whose E-job would then run
// longer than planned), and every ray and sample is still accounted for.
TEST(PathTraceConservation, NoMergesIntoPlannedJobs) {
  const Outcome on = run(Fidelity::Markov, 0);
  const Outcome off = run(Fidelity::Markov, 0, nullptr, nullptr, 2, 2, 7, false);
  expect_conserved(off, 2, 2);
  EXPECT_EQ(off.merges_into_planned, 0u);
  EXPECT_GT(on.merges_into_planned, 0u) << "the default merges into planned jobs (this test would prove nothing)";
  const Outcome off_pred = run(Fidelity::Markov, 2, nullptr, nullptr, 2, 2, 7, false);
  expect_conserved(off_pred, 2, 2);
  EXPECT_EQ(off_pred.merges_into_planned, 0u);
}

// Rayline's policy: scene replicated (the platform's memories hold it), and split over the
// two nodes (host 500 MB, GPU 200 MB: 800 MB of scene fits no node), rays crossing the LAN
// to their block's owner.
TEST(PathTraceConservation, RaylinePolicyReplicatedAndSplit) {
  expect_conserved(run(Fidelity::Markov, 0, nullptr, nullptr, 2, 2, 7, true, true, true, {}, "rayline"), 2, 2);
  std::size_t lan_queues = 0;
  const Inspect lan = [&](const DeviceGraph& g, const JobPool& pool, const Schedule& s, const PathTraceWorkload&) {
    for (std::size_t i = 0; i < s.activity_count(); ++i) {
      const Activity& a = s.activity(static_cast<ActivityId>(i));
      if (a.kind != ActivityKind::Transfer) continue;
      const Channel& c = g.channels[a.channel];
      if (g.memories[c.from].node == g.memories[c.to].node) continue;
      EXPECT_NE(pool.block(a.block).kind, DataKind::SceneData) << "scene data crossed the LAN";
      lan_queues += pool.block(a.block).kind == DataKind::RayQueue || pool.block(a.block).kind == DataKind::ShadowRayQueue;
    }
  };
  expect_conserved(run(Fidelity::Markov, 0, nullptr, nullptr, 2, 2, 7, true, true, true, lan, "rayline", 500'000'000,
                       200'000'000),
                   2, 2);
  EXPECT_GT(lan_queues, 0u) << "split ownership moves ray queues to their owners";
}

// Rayline's rule 8: with the scene split between the two nodes, each wave becomes one
// GenerateRays job per owner of the blocks its rays enter (on this profile a wave's rays enter
// one block), each runs on its owner, and every
// ray and sample is still accounted for (the entry split is drawn when the wave is
// requested, the rays counted when each job ends).
TEST(PathTraceConservation, RaylineCameraRaysMadeByTheirOwners) {
  std::size_t generate = 0, hinted = 0;
  std::set<NodeId> nodes;
  const Inspect where = [&](const DeviceGraph& g, const JobPool& pool, const Schedule& s, const PathTraceWorkload&) {
    for (std::size_t i = 0; i < s.activity_count(); ++i) {
      const Activity& a = s.activity(static_cast<ActivityId>(i));
      if (a.kind != ActivityKind::Exec || g.job_types[static_cast<std::size_t>(pool.job(a.job).type)] != "GenerateRays") continue;
      ++generate;
      const NodeId hint = pool.job(a.job).node_hint;
      if (hint == kNone) continue;
      ++hinted;
      nodes.insert(hint);
      EXPECT_EQ(g.computes[a.device].node, hint) << "job " << a.job << " runs on the node it was made for";
    }
  };
  const Outcome on = run(Fidelity::Markov, 0, nullptr, nullptr, 2, 2, 7, true, true, true, where, "rayline", 500'000'000,
                         200'000'000, nullptr, true);
  expect_conserved(on, 2, 2);
  EXPECT_EQ(hinted, generate) << "every wave was split by owner";
  EXPECT_EQ(nodes.size(), 2u) << "both owners make rays";
  const std::size_t with_rule = generate;
  generate = hinted = 0;
  expect_conserved(run(Fidelity::Markov, 0, nullptr, nullptr, 2, 2, 7, true, true, true, where, "rayline", 500'000'000,
                       200'000'000),
                   2, 2);
  EXPECT_EQ(hinted, 0u) << "off by default";
  EXPECT_GE(with_rule, generate) << "a wave is at least one job";
}

// The workload's side of rule 8 on its own, under GMB (which ignores the hints): an origin
// that splits every wave by its entry blocks' parity makes waves of two jobs, hinted 0 and
// 1, and the rays and samples stay exact.
TEST(PathTraceConservation, WavesSplitByRayOriginConserveRays) {
  std::size_t generate = 0;
  std::set<NodeId> hints;
  const Inspect count = [&](const DeviceGraph& g, const JobPool& pool, const Schedule&, const PathTraceWorkload&) {
    for (std::size_t j = 0; j < pool.job_count(); ++j) {
      const Job& job = pool.job(static_cast<JobId>(j));
      if (g.job_types[static_cast<std::size_t>(job.type)] != "GenerateRays") continue;
      ++generate;
      hints.insert(job.node_hint);
    }
  };
  expect_conserved(run(Fidelity::Markov, 0, nullptr, nullptr, 2, 2, 7, true, true, true, count), 2, 2);
  const std::size_t whole = generate;
  EXPECT_EQ(hints, std::set<NodeId>{kNone});
  generate = 0;
  hints.clear();
  const auto parity = [](std::uint64_t, BlockId entry) { return static_cast<NodeId>(entry % 2); };
  for (const Fidelity fid : {Fidelity::Analytic, Fidelity::Markov})
    expect_conserved(run(fid, 0, nullptr, nullptr, 2, 2, 7, true, true, true, count, "gmb", 0, 0, nullptr, false, parity), 2,
                     2);
  EXPECT_EQ(hints, (std::set<NodeId>{0, 1}));
  EXPECT_GT(generate, 2 * whole) << "waves entering blocks of both parities are two jobs";
}

// Device-sized jobs (Rayline's rule 7): no ray job holds more than its type's cap, queues
// larger than it are split into several jobs, and every ray and sample is still accounted
// for. A cap of 16 KiB (256 rays of 64 B) splits nearly every queue; the policy's own caps
// (a quarter of its look-ahead on paper-2A's fastest device) leave the same run conserved.
TEST(PathTraceConservation, DeviceSizedJobsHoldAtMostTheirCapAndConserveRays) {
  const std::vector<Bytes> tiny(16, 16 << 10);
  for (const std::vector<Bytes>* caps : {static_cast<const std::vector<Bytes>*>(nullptr), &tiny}) {
    std::size_t ray_jobs = 0, over = 0;
    std::uint64_t rays = 0;
    const Inspect check = [&](const DeviceGraph& g, const JobPool& pool, const Schedule&, const PathTraceWorkload& wl) {
      const std::vector<Bytes> in_force = caps ? *caps : job_caps(SchedulerChoice{.kind = SchedulerKind::Rayline}, g);
      const SceneProfile prof = load_scene_profile(kProfile);
      for (std::size_t j = 0; j < pool.job_count(); ++j) {
        const JobTypeId t = pool.job(static_cast<JobId>(j)).type;
        const std::string& name = g.job_types[static_cast<std::size_t>(t)];
        const Bytes per = name == "RayIntersect" ? prof.ray_bytes : name == "ShadowIntersect" ? prof.shadow_ray_bytes
                          : name == "Shade"      ? prof.hit_bytes : 0;
        if (per == 0) continue;
        const std::uint64_t n = wl.job_rays(static_cast<JobId>(j));
        ++ray_jobs;
        rays += n;
        if (n > std::max<std::uint64_t>(1, in_force.at(static_cast<std::size_t>(t)) / per)) ++over;
      }
    };
    const Outcome r = run(Fidelity::Markov, 0, nullptr, nullptr, 2, 2, 7, true, true, true, check, "rayline", 0, 0, caps);
    expect_conserved(r, 2, 2);
    EXPECT_GT(ray_jobs, 0u);
    EXPECT_GT(rays, 0u);
    EXPECT_EQ(over, 0u) << "ray jobs above their cap, of " << ray_jobs;
    if (caps) {
      EXPECT_GE(ray_jobs, rays / 256) << "a 256-ray cap makes at least one job per 256 rays";
    }
  }
}

TEST(PathTraceConservation, OneClientManyFrames) { expect_conserved(run(Fidelity::Markov, 1, nullptr, nullptr, 1, 4), 1, 4); }

// Rays joining a planned, not yet started job (and a confirmed prediction's real rays)
// re-time its E-job (Schedule::retime): every ray job's planned duration is then Eq. 2 of
// the queue it processed. Without re-timing some run longer than the plan says.
TEST(PathTraceConservation, PlannedJobsThatRaysJoinAreRetimed) {
  for (const bool retime : {true, false}) {
    std::size_t checked = 0, off = 0, merges = 0;
    const Outcome r = run(Fidelity::Markov, 2, nullptr, nullptr, 2, 2, 7, true, true, retime,
                          [&](const DeviceGraph& g, const JobPool& pool, const Schedule& s, const PathTraceWorkload& wl) {
                            merges = wl.merges_into_planned();
                            for (std::size_t i = 0; i < s.activity_count(); ++i) {
                              const Activity& a = s.activity(static_cast<ActivityId>(i));
                              if (a.kind != ActivityKind::Exec || a.cancelled || wl.job_rays(a.job) == 0) continue;
                              // GenerateRays is timed by its request, not by rays
                              if (g.job_types[static_cast<std::size_t>(pool.job(a.job).type)] == "GenerateRays") continue;
                              ++checked;
                              const Time want = wl.exec_time_now(a.job, a.device);
                              if (std::abs(a.duration - want) > 1e-12 * std::max(1.0, want)) ++off;
                            }
                          });
    expect_conserved(r, 2, 2);
    ASSERT_GT(merges, 0u);
    ASSERT_GT(checked, 100u);
    if (retime) EXPECT_EQ(off, 0u) << "of " << checked << " ray jobs";
    else EXPECT_GT(off, 0u) << "merges make E-jobs run longer than planned";
  }
}

TEST(PathTraceReplay, ReproducesRecordedPerJobRayCountsExactly) {
  Outcome rec;
  auto log = recorded(&rec);
  const Outcome rep = run(Fidelity::Replay, 0, log);
  EXPECT_EQ(rep.fallback, 0u);
  EXPECT_GT(rep.exact_pieces, 0u);
  ASSERT_EQ(rep.job_rays.size(), rec.job_rays.size());
  EXPECT_EQ(rep.job_types, rec.job_types);
  EXPECT_EQ(rep.job_rays, rec.job_rays);
  EXPECT_EQ(rep.tally.hit, rec.tally.hit);
  EXPECT_EQ(rep.tally.escaped, rec.tally.escaped);
  EXPECT_EQ(rep.tally.occluded, rec.tally.occluded);
  EXPECT_EQ(rep.tally.lit, rec.tally.lit);
}

TEST(PathTraceReplay, ReproducesPerJobCountsWithPrediction) {
  Outcome rec;
  auto log = recorded(&rec, 2);
  const Outcome rep = run(Fidelity::Replay, 2, log);
  EXPECT_EQ(rep.job_rays, rec.job_rays);
  EXPECT_EQ(rep.tally.created(), rec.tally.created());
}

TEST(PathTraceReplay, LogRoundTripsThroughItsFile) {
  Outcome rec;
  auto log = recorded(&rec);
  const std::string path = ::testing::TempDir() + "/replay-roundtrip.log";
  log->save(path, "test");
  auto loaded = std::make_shared<ReplayLog>(ReplayLog::load(path));
  EXPECT_EQ(loaded->pieces(), log->pieces());
  const Outcome rep = run(Fidelity::Replay, 0, loaded);
  EXPECT_EQ(rep.job_rays, rec.job_rays);
}

// A damaged log is refused at load, naming the file and the line, before it can reach the
// model (a category or block the profile lacks used to fail mid-simulation; found by
// fuzzing): whole tokens only, categories and blocks checked against the profile.
TEST(PathTraceReplay, DamagedLogsNameTheFileAndLine) {
  auto log = recorded();
  const std::string path = ::testing::TempDir() + "/replay-good.log";
  log->save(path, "test");
  std::vector<std::string> lines;
  {
    std::ifstream in(path);
    for (std::string l; std::getline(in, l);) lines.push_back(l);
  }
  // The first shade piece ("shade CLIENT FRAME TILE BOUNCE BLOCK N 0:a 1:b").
  std::size_t shade = 0;
  while (shade < lines.size() && !lines[shade].starts_with("shade ")) ++shade;
  ASSERT_LT(shade, lines.size());
  const SceneProfile profile = load_scene_profile(kProfile);
  const std::string where = "line " + std::to_string(shade + 1);
  auto words = [&] {
    std::vector<std::string> w;
    std::istringstream ss(lines[shade]);
    for (std::string t; ss >> t;) w.push_back(t);
    return w;
  };
  auto join = [](const std::vector<std::string>& w) {
    std::string s;
    for (const auto& t : w) s += (s.empty() ? "" : " ") + t;
    return s;
  };
  std::vector<std::pair<std::string, std::string>> cases;  // damaged line, expected words
  {
    auto w = words();
    w.back() = "2" + w.back().substr(w.back().find(':'));  // shading has categories 0 and 1
    cases.emplace_back(join(w), "category 2");
  }
  {
    auto w = words();
    w[5] = std::to_string(profile.blocks.size());
    cases.emplace_back(join(w), "out of range");
  }
  {
    auto w = words();
    w.back() = "1:5:5";  // once accepted as 1:5
    cases.emplace_back(join(w), "bad count");
  }
  {
    auto w = words();
    w[1] = "-1";
    cases.emplace_back(join(w), "malformed piece");
  }
  {
    auto w = words();
    w.back() = "1:18446744073709551615";
    cases.emplace_back(join(w), "overflow");
  }
  for (const auto& [bad, expect] : cases) {
    const std::string damaged = ::testing::TempDir() + "/replay-damaged.log";
    {
      std::ofstream out(damaged);
      for (std::size_t i = 0; i < lines.size(); ++i) out << (i == shade ? bad : lines[i]) << "\n";
    }
    try {
      (void)ReplayLog::load(damaged, &profile);
      ADD_FAILURE() << "accepted: " << bad;
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(damaged), std::string::npos) << what;
      EXPECT_NE(what.find(where), std::string::npos) << what;
      EXPECT_NE(what.find(expect), std::string::npos) << bad << " -> " << what;
    }
  }
  EXPECT_EQ(ReplayLog::load(path, &profile).pieces(), log->pieces());  // the intact log loads
}

TEST(PathTraceDeterminism, SameSeedSameRun) {
  const Outcome a = run(Fidelity::Markov, 2), b = run(Fidelity::Markov, 2);
  EXPECT_EQ(a.job_rays, b.job_rays);
  EXPECT_EQ(a.tally.created(), b.tally.created());
}

namespace {
// The path-tracing workload under GMB and the exact executor, run to the end (with faults).
struct GmbRun {
  GmbRun(const DeviceGraph& g, const SceneProfile& prof, const PathTraceOptions& o, const std::vector<Fault>& faults = {})
      : s(g, pool), wl(g, prof, o), ex(s), loop(gmb, ex, wl, pool, s) {
    for (const Fault& f : faults) loop.add_fault(f);
    stats = loop.run();
  }
  JobPool pool;
  Schedule s;
  PathTraceWorkload wl;
  GmbScheduler gmb;
  ExactExecutor ex;
  RuntimeLoop loop;
  RunStats stats;
};
}  // namespace

// Faults (docs/faults.md): a whole node lost mid-frame. Its queues go with it; the
// workload abandons each frame that had work there and its client asks for the frame
// again. The run completes with every client's frames delivered exactly (spp samples per
// pixel), and the rays are accounted for exactly: created = ended + lost.
TEST(PathTraceFaults, NodeLostMidFrameFramesRenderedAgainConservationExact) {
  const DeviceGraph g = load_platform(std::string(RAYLINE_PLATFORMS) + "/paper-2A.json");
  const SceneProfile prof = load_scene_profile(kProfile);
  int hit = 0;
  for (const Time at : {0.05, 0.2, 0.5, 1.0}) {
    PathTraceOptions o;
    o.clients = 2;
    o.frames_per_client = 2;
    o.seed = 7;
    // The node that does not hold the clients (their framebuffers are on the first host memory).
    GmbRun r(g, prof, o, {parse_fault(g.nodes.back().name + "@" + std::to_string(at) + "s", g)});
    const RunStats& st = r.stats;
    const PathTraceWorkload& wl = r.wl;
    const Schedule& s = r.s;
    EXPECT_FALSE(st.stalled) << "at " << at;
    EXPECT_EQ(st.faults, 1) << "at " << at;
    EXPECT_EQ(wl.tally().created(), wl.tally().ended() + wl.tally().lost) << "at " << at;
    EXPECT_EQ(wl.rays_alive(), 0u) << "at " << at;
    ASSERT_EQ(wl.frames().size(), 4u) << "at " << at;
    for (const FrameReport& f : wl.frames()) EXPECT_TRUE(f.exact) << "at " << at << " client " << f.client;
    // Nothing ran on the lost node after the fault.
    for (std::size_t i = 0; i < s.activity_count(); ++i) {
      const Activity& a = s.activity(static_cast<ActivityId>(i));
      if (a.state != ActivityState::Done) continue;
      const bool lost = a.kind == ActivityKind::Exec ? !s.compute_alive(a.device) : !s.channel_alive(a.channel);
      if (lost) {
        EXPECT_LE(a.end, at + 1e-9) << "activity " << i;
      }
    }
    hit += wl.abandoned_frames().empty() ? 0 : 1;
    if (HasFailure()) return;
  }
  EXPECT_GT(hit, 0) << "some fault must have taken work that a frame needed";
}

// The platform's "clients" names the host memory the clients keep their framebuffers on:
// there, not on the first host memory, and every frame is composed there, exact.
TEST(PathTraceClients, FramebuffersLiveOnThePlatformsClientMemory) {
  DeviceGraph g = load_platform(std::string(RAYLINE_PLATFORMS) + "/paper-2A.json");
  const MemId second = g.find_memory(g.nodes.back().name + ".ram");
  ASSERT_NE(second, kNone);
  g.client_memory = second;
  const SceneProfile prof = load_scene_profile(kProfile);
  PathTraceOptions o;
  o.clients = 2;
  o.frames_per_client = 1;
  o.seed = 3;
  GmbRun r(g, prof, o);
  EXPECT_FALSE(r.stats.stalled);
  EXPECT_EQ(r.wl.client_memory(), second);
  EXPECT_EQ(r.wl.client_framebuffer_bytes(), 2u * Bytes(prof.width) * Bytes(prof.height) * prof.framebuffer_bytes_per_pixel);
  int framebuffers = 0;
  for (std::size_t b = 0; b < r.pool.block_count(); ++b)
    if (r.pool.block(static_cast<BlockId>(b)).name.starts_with("framebuffer.client")) {
      ++framebuffers;
      EXPECT_NE(r.s.copy_at(static_cast<BlockId>(b), second), nullptr) << r.pool.block(static_cast<BlockId>(b)).name;
      EXPECT_EQ(r.s.copies(static_cast<BlockId>(b)).size(), 1u);
    }
  EXPECT_EQ(framebuffers, 2);
  ASSERT_EQ(r.wl.frames().size(), 2u);
  for (const FrameReport& f : r.wl.frames()) EXPECT_TRUE(f.exact) << "client " << f.client;
}

// Several frames in flight per client (more offered load): conservation stays exact, every
// frame is delivered exact, frame indices along each client's camera path are 0..n-1.
TEST(PathTraceFramesInFlight, ConservationExactWithThreeFramesInFlight) {
  const DeviceGraph g = load_platform(std::string(RAYLINE_PLATFORMS) + "/paper-2A.json");
  const SceneProfile prof = load_scene_profile(kProfile);
  PathTraceOptions o;
  o.clients = 2;
  o.frames_per_client = 4;
  o.frames_in_flight = 3;
  o.seed = 11;
  GmbRun r(g, prof, o);
  const RunStats& st = r.stats;
  const PathTraceWorkload& wl = r.wl;
  EXPECT_FALSE(st.stalled);
  EXPECT_EQ(wl.tally().created(), wl.tally().ended());
  EXPECT_EQ(wl.rays_alive(), 0u);
  ASSERT_EQ(wl.frames().size(), 8u);
  std::vector<std::vector<int>> seen(2);
  for (const FrameReport& f : wl.frames()) {
    EXPECT_TRUE(f.exact) << "client " << f.client << " frame " << f.index;
    seen[static_cast<std::size_t>(f.client)].push_back(f.index);
  }
  for (auto& v : seen) {
    std::sort(v.begin(), v.end());
    EXPECT_EQ(v, (std::vector<int>{0, 1, 2, 3}));
  }
  // More than one frame of a client was in flight at once: some frame was requested
  // before the one before it was delivered.
  bool overlapped = false;
  for (const FrameReport& a : wl.frames())
    for (const FrameReport& b : wl.frames())
      overlapped = overlapped || (a.client == b.client && a.index + 1 == b.index && b.requested < a.delivered);
  EXPECT_TRUE(overlapped);
}

// Waves carry their tiles only when asked (replay): otherwise one count under tile 0 with
// the same total, and the same units consumed.
TEST(PathTraceClients, WavesCarryTilesOnlyWhenAsked) {
  const SceneProfile prof = load_scene_profile(kProfile);
  FrameState a, b;
  a.units_total = b.units_total = static_cast<std::uint64_t>(prof.spp) * static_cast<std::uint64_t>(prof.tiles());
  const RayCounts tiled = next_wave(prof, 3, a, true), flat = next_wave(prof, 3, b, false);
  EXPECT_EQ(a.next_unit, b.next_unit);
  EXPECT_EQ(total(tiled), total(flat));
  ASSERT_EQ(flat.size(), 1u);
  EXPECT_EQ(flat[0].first, ray_key(3, 0, 0));
  EXPECT_EQ(tiled.size(), std::min<std::uint64_t>(a.next_unit, static_cast<std::uint64_t>(prof.tiles())));
}

// Expected tiles covered by n uniformly spread samples: 0 for none, 1 for one, never more
// than the tiles, monotone, and every tile once samples far outnumber tiles.
TEST(PathTraceClients, PartialTilesIsTheExpectedCoverage) {
  EXPECT_EQ(partial_tiles(0, 64), 0u);
  EXPECT_EQ(partial_tiles(1, 64), 1u);
  EXPECT_EQ(partial_tiles(2, 64), 2u);  // 1.98 rounded up
  EXPECT_EQ(partial_tiles(64, 64), 41u);  // 64 (1 - (63/64)^64) = 40.6
  EXPECT_EQ(partial_tiles(100000, 64), 64u);
  EXPECT_EQ(partial_tiles(5, 1), 1u);
  std::uint64_t last = 0;
  for (std::uint64_t n = 0; n < 2000; n += 7) {
    const std::uint64_t t = partial_tiles(n, 64);
    EXPECT_GE(t, last);
    EXPECT_LE(t, 64u);
    last = t;
  }
}

namespace {
// paper-NAME with RAM half and GPU memory a quarter of the scene's bytes.
DeviceGraph tight_platform(const std::string& name, const SceneProfile& prof) {
  Bytes scene = 0;
  for (const ProfileBlock& b : prof.blocks) scene += b.bytes;
  DeviceGraph g = load_platform(std::string(RAYLINE_PLATFORMS) + "/" + name + ".json");
  for (MemoryDevice& m : g.memories) {
    if (m.kind == MemoryKind::Host) m.capacity = scene / 2;
    if (m.kind == MemoryKind::Gpu) m.capacity = scene / 4;
  }
  return g;
}

// Every activity of a whole run under `sched`, with reality off the plan: each activity runs
// 0.5-1.8x its planned time (seeded by o.seed).
std::vector<Activity> perturbed_plan(const DeviceGraph& g, const SceneProfile& prof, const PathTraceOptions& o,
                                     Scheduler& sched, bool kept_leaving_order = true) {
  JobPool pool;
  Schedule s(g, pool);
  s.set_kept_leaving_order(kept_leaving_order);
  PathTraceWorkload wl(g, prof, o);
  ExactExecutor ex(s);
  auto rng = std::make_shared<std::mt19937>(static_cast<std::uint32_t>(o.seed));
  ex.perturb = [rng](ActivityId, const Activity& a) {
    return a.duration * std::uniform_real_distribution<double>(0.5, 1.8)(*rng);
  };
  RuntimeLoop loop(sched, ex, wl, pool, s);
  if (loop.run().stalled) ADD_FAILURE() << "stalled";
  std::vector<Activity> plan;
  for (std::size_t i = 0; i < s.activity_count(); ++i) plan.push_back(s.activity(static_cast<ActivityId>(i)));
  return plan;
}

// The same plan, activity by activity: placement, planned and actual times, state, deps.
void expect_same_plan(const std::vector<Activity>& x, const std::vector<Activity>& y, const std::string& what) {
  for (std::size_t i = 0; i < std::min(x.size(), y.size()); ++i) {
    const Activity& a = x[i];
    const Activity& b = y[i];
    ASSERT_TRUE(a.kind == b.kind && a.job == b.job && a.device == b.device && a.channel == b.channel &&
                a.block == b.block && a.planned_start == b.planned_start && a.planned_end == b.planned_end &&
                a.start == b.start && a.end == b.end && a.state == b.state && a.cancelled == b.cancelled &&
                std::equal(a.deps.begin(), a.deps.end(), b.deps.begin(), b.deps.end()))
        << what << ": activity " << i << " differs (job " << a.job << "/" << b.job << ", start " << a.start << "/"
        << b.start << ")";
  }
  ASSERT_EQ(x.size(), y.size()) << what;
}
}  // namespace

// Schedule::admission keeps each device's leaving entries sorted while no activity's end
// moves (new entries merged in, gone ones dropped where met). It must choose exactly what
// a fresh sort at every call chooses: the same plan, activity by activity, for GMB and
// Rayline's policy on memories too small for the scene, with reality off the plan and
// predictions withdrawn (ends move, entries come and go).
TEST(PathTraceDeterminism, KeptLeavingOrderPlansAsAFreshSort) {
  const SceneProfile prof = load_scene_profile(kProfile);
  const DeviceGraph g = tight_platform("paper-2A", prof);
  for (const std::string scheduler : {"gmb", "rayline"}) {
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      PathTraceOptions o;
      o.clients = 3;
      o.frames_per_client = 2;
      o.prediction_depth = 2;
      o.seed = seed;
      std::vector<Activity> plan[2];
      for (int kept = 0; kept < 2; ++kept) {
        const std::unique_ptr<Scheduler> sched = make_scheduler(scheduler, 2.0);
        plan[kept] = perturbed_plan(g, prof, o, *sched, kept == 1);
      }
      expect_same_plan(plan[0], plan[1], scheduler + " seed " + std::to_string(seed));
      if (HasFatalFailure()) return;
    }
  }
}

// Rayline's policy does not plan again a node asked only for an idle device while nothing on
// it changed (RaylineOptions::skip_unchanged): the plan must be the one planning every such
// node at every call gives, activity by activity, on memories too small for the scene, with
// reality off the plan (ends move earlier and later), under the default rules, rule 4's hold
// (jobs held while the node is busy), and without ownership; on two nodes and on eight.
TEST(PathTraceDeterminism, RaylineSkipsOnlyNodesWhosePlanWouldBeTheSame) {
  const SceneProfile prof = load_scene_profile(kProfile);
  std::uint64_t skipped = 0;
  for (const std::string platform : {"paper-2A", "paper-cluster"}) {
    const DeviceGraph g = tight_platform(platform, prof);
    for (const std::string rules : {"", "hold", "no-ownership"}) {
      for (std::uint64_t seed = 1; seed <= 2; ++seed) {
        PathTraceOptions o;
        o.clients = 4;
        o.frames_per_client = 2;
        o.seed = seed;
        std::vector<Activity> plan[2];
        for (int skip = 0; skip < 2; ++skip) {
          RaylineOptions ro = rayline_options(0.5, rules == "no-ownership" ? rayline_rule_bit("ownership") : 0u,
                                              rules == "hold" ? rayline_rule_bit("hold") : 0u);
          ro.skip_unchanged = skip == 1;
          RaylineScheduler sched(ro);
          plan[skip] = perturbed_plan(g, prof, o, sched);
          if (skip == 0) {
            EXPECT_EQ(sched.skipped(), 0u);
          }
          skipped += sched.skipped();
        }
        expect_same_plan(plan[0], plan[1], platform + " " + rules + " seed " + std::to_string(seed));
        if (HasFatalFailure()) return;
      }
    }
  }
  EXPECT_GT(skipped, 100u) << "the runs must skip nodes, or the comparison shows nothing";
  std::printf("[skip] %llu node plans skipped, every plan the same\n", static_cast<unsigned long long>(skipped));
}

// Placer::earliest_start searches only the Pareto front (ready time, size) of a merged job's
// one-copy inputs. Checked against an independent reference, the exact SDC arrival of every
// input (FetchPathFinder::arrival), before every plan of whole runs: Budge and Rayline's
// policy merge hundreds of ray queues into one job, and on the 4-GPU workstation the
// clients' AdditiveCompose jobs read framebuffers that cannot move next to ones that can.
TEST(PathTraceDeterminism, EarliestStartOfManyInputsIsTheLatestExactArrival) {
  struct Checking final : Scheduler {
    std::unique_ptr<Scheduler> inner;
    std::unique_ptr<Placer> placer;
    std::size_t checked = 0, never = 0, mismatches = 0;
    std::string name() const override { return inner->name(); }
    bool plans_while_idle() const override { return inner->plans_while_idle(); }
    PlanStats plan(Time now, JobPool& pool, Schedule& s) override {
      if (!placer) placer = std::make_unique<Placer>(s);
      const DeviceGraph& g = s.graph();
      for (const JobId j : pool.queued()) {
        const Job& job = pool.job(j);
        if (job.inputs.size() <= 4 || checked > 4000) continue;
        for (DeviceId d = 0; d < static_cast<DeviceId>(g.computes.size()); ++d) {
          if (!g.timing.supports(d, job.type)) continue;
          placer->finder().clear();
          placer->finder().set_now(now);
          const Time got = placer->earliest_start(j, d, now, s);
          const MemId m = g.computes[d].memory;
          Time want = std::max(now, s.after_deps_ready(j));
          for (BlockId b : job.inputs) {
            const Copy* c = s.copy_at(b, m);
            if (!c && !Placer::may_fetch(job, b, s)) want = kNever;
            if (want == kNever) break;
            want = std::max(want, c ? s.copy_ready(*c) : placer->finder().arrival(b, m));
          }
          ++checked;
          never += want == kNever;
          if (got != want) ++mismatches;
        }
      }
      return inner->plan(now, pool, s);
    }
  };
  const SceneProfile prof = load_scene_profile(kProfile);
  std::size_t checked = 0, never = 0;
  for (const std::string platform : {"paper-2A.json", "workstation-4gpu.json"})
    for (const std::string scheduler : {"budge", "rayline"}) {
      DeviceGraph g = load_platform(std::string(RAYLINE_PLATFORMS) + "/" + platform);
      PathTraceOptions o;
      o.clients = 4;
      o.frames_per_client = 2;
      o.seed = 3;
      JobPool pool;
      Schedule s(g, pool);
      PathTraceWorkload wl(g, prof, o);
      Checking sched;
      sched.inner = make_scheduler(scheduler, 2.0);
      ExactExecutor ex(s);
      RuntimeLoop loop(sched, ex, wl, pool, s);
      ASSERT_FALSE(loop.run().stalled) << platform << " " << scheduler;
      EXPECT_EQ(sched.mismatches, 0u) << platform << " " << scheduler << ": of " << sched.checked;
      checked += sched.checked;
      never += sched.never;
    }
  EXPECT_GT(checked, 1000u) << "jobs of many inputs were checked";
  EXPECT_GT(never, 0u) << "some could not run on some device (a framebuffer that cannot move)";
}
