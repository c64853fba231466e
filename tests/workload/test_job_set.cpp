// Job-set files (rayline plan --jobs): parsing, every bad-input case naming the field,
// the synthetic generator's determinism, and the trace / CSV outputs of a planned set.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <sstream>

#include "sched/dcg_fixture.hpp"
#include "common/error.hpp"
#include "sched/runtime/exact_executor.hpp"
#include "sched/policy/gmb/gmb_scheduler.hpp"
#include "workload/job_set.hpp"
#include "sched/runtime/runtime_loop.hpp"
#include "sched/io/trace_output.hpp"
#include "sched/timeline/utilisation.hpp"

using namespace rayline;

namespace {
DeviceGraph two_node_graph() {
  rayline::testing::DcgBuilder b;
  const NodeId n0 = b.node("n0"), n1 = b.node("n1");
  const MemId d0 = b.mem("n0.disk", Bytes(1) << 40, MemoryKind::Disk, n0);
  const MemId r0 = b.mem("n0.ram", Bytes(8) << 30, MemoryKind::Host, n0);
  const MemId r1 = b.mem("n1.ram", Bytes(8) << 30, MemoryKind::Host, n1);
  b.half_duplex(d0, r0, 150e6, 0.01);
  b.full_duplex(r0, r1, 125e6, 1e-4);
  b.dev("n0.cpu0", r0);
  b.dev("n1.cpu0", r1);
  b.timing(0, DataKind::RayQueue, 32e6, 5e-6);
  return b.build();
}

const char* kGood = R"({
  "name": "tiny",
  "blocks": [
    {"name": "scene0", "kind": "SceneData", "size": "200MB", "at": ["n0.disk"]},
    {"name": "rays0", "kind": "RayQueue", "size": "32MB", "at": ["n1.ram"], "scene_block": "scene0"},
    {"name": "rays1", "kind": "RayQueue", "size": "16MB", "at": ["n0.ram"], "scene_block": "scene0"},
    {"name": "hits0", "kind": "RayQueue", "size": "8MB"}
  ],
  "jobs": [
    {"name": "j0", "type": "RayIntersect", "inputs": ["scene0", "rays0"], "outputs": ["hits0"], "work": 500000},
    {"name": "j1", "type": "RayIntersect", "inputs": ["scene0", "rays1"]},
    {"name": "j2", "type": "RayIntersect", "inputs": ["scene0", "hits0"], "after": ["j1"], "created": "0s"}
  ]
})";

std::string error_of(const std::string& text) {
  try {
    parse_job_set(text, "jobs.json", two_node_graph());
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

std::string with(const std::string& from, const std::string& to) {
  std::string s = kGood;
  const auto p = s.find(from);
  if (p == std::string::npos) throw std::logic_error("fixture text not found: " + from);
  return s.replace(p, from.size(), to);
}
}  // namespace

TEST(JobSet, ParsesBlocksJobsAndDependencies) {
  const DeviceGraph g = two_node_graph();
  JobSet set = parse_job_set(kGood, "jobs.json", g);
  ASSERT_EQ(set.pool.block_count(), 4u);
  ASSERT_EQ(set.pool.job_count(), 3u);
  EXPECT_EQ(set.pool.block(1).kind, DataKind::RayQueue);
  EXPECT_TRUE(set.pool.block(1).consumed);
  EXPECT_EQ(set.pool.block(1).scene_block, 0);
  EXPECT_EQ(set.pool.block(0).bytes, 200000000u);
  EXPECT_EQ(set.pool.producer(3), 0);
  EXPECT_EQ(set.pool.job(2).after, std::vector<JobId>{1});
  EXPECT_EQ(set.pool.job(0).work, 500000u);
  EXPECT_EQ(set.initial.size(), 3u);
}

TEST(JobSet, BadInputNamesTheField) {
  EXPECT_NE(error_of("{").find("invalid JSON"), std::string::npos);
  EXPECT_NE(error_of(with("\"name\": \"tiny\",", "\"nmae\": \"tiny\",")).find("$.nmae: unknown key"), std::string::npos);
  EXPECT_NE(error_of(with("\"size\": \"200MB\"", "\"size\": \"200 parsecs\"")).find("blocks[0].size"), std::string::npos);
  EXPECT_NE(error_of(with("\"kind\": \"SceneData\"", "\"kind\": \"Scenery\"")).find("blocks[0].kind: unknown data kind"), std::string::npos);
  EXPECT_NE(error_of(with("[\"n0.disk\"]", "[\"n9.disk\"]")).find("blocks[0].at: unknown memory device 'n9.disk'"), std::string::npos);
  EXPECT_NE(error_of(with("\"type\": \"RayIntersect\", \"inputs\": [\"scene0\", \"rays1\"]", "\"type\": \"Teleport\", \"inputs\": [\"scene0\", \"rays1\"]"))
                .find("jobs[1].type: unknown job type 'Teleport'"), std::string::npos);
  EXPECT_NE(error_of(with("\"inputs\": [\"scene0\", \"rays1\"]", "\"inputs\": [\"scene0\", \"rays9\"]")).find("jobs[1].inputs: unknown block 'rays9'"), std::string::npos);
  EXPECT_NE(error_of(with("\"after\": [\"j1\"]", "\"after\": [\"j7\"]")).find("jobs[2].after: unknown job 'j7'"), std::string::npos);
  EXPECT_NE(error_of(with("{\"name\": \"j1\", \"type\": \"RayIntersect\", \"inputs\": [\"scene0\", \"rays1\"]}",
                          "{\"name\": \"j1\", \"type\": \"RayIntersect\", \"inputs\": [\"scene0\", \"rays1\"], \"after\": [\"j2\"]}"))
                .find("dependency cycle"), std::string::npos);
  EXPECT_NE(error_of(with("\"outputs\": [\"hits0\"]", "\"outputs\": [\"rays1\"]")).find("placed initially and produced"), std::string::npos);
  // An unused block is fine.
  EXPECT_EQ(error_of(with("{\"name\": \"hits0\", \"kind\": \"RayQueue\", \"size\": \"8MB\"}",
                          "{\"name\": \"hits0\", \"kind\": \"RayQueue\", \"size\": \"8MB\"}, "
                          "{\"name\": \"orphan\", \"kind\": \"Generic\", \"size\": \"1MB\", \"at\": [\"n0.ram\"]}")),
            "");
  EXPECT_NE(error_of(with("\"outputs\": [\"hits0\"], ", "")).find("neither placed"), std::string::npos);
  EXPECT_NE(error_of(with("\"name\": \"rays1\"", "\"name\": \"rays0\"")).find("duplicate block name"), std::string::npos);
  EXPECT_NE(error_of(with("\"created\": \"0s\"", "\"created\": \"-3s\"")).find("jobs[2].created"), std::string::npos);
  // Found by mutation fuzzing of `rayline plan --jobs`: each of these must be refused
  // here, naming file and field, not reach the Schedule's own consistency checks (exit 1,
  // no file or field) or plan a job that could never run.
  EXPECT_NE(error_of(with("[\"n0.disk\"]", "[\"n0.disk\", \"n0.disk\"]")).find("blocks[0].at: memory device 'n0.disk' listed twice"),
            std::string::npos);
  EXPECT_NE(error_of(with("\"inputs\": [\"scene0\", \"rays1\"]", "\"inputs\": [\"scene0\", \"rays1\", \"rays1\"]"))
                .find("jobs[1].inputs: block 'rays1' listed twice"), std::string::npos);
  EXPECT_NE(error_of(with("\"inputs\": [\"scene0\", \"rays1\"]", "\"inputs\": [\"scene0\", \"scene0\", \"rays1\"]"))
                .find("jobs[1].inputs: block 'scene0' listed twice"), std::string::npos);
  EXPECT_NE(error_of(with("\"outputs\": [\"hits0\"]", "\"outputs\": [\"hits0\", \"hits0\"]"))
                .find("jobs[0].outputs: block 'hits0' listed twice"), std::string::npos);
  EXPECT_NE(error_of(with("\"inputs\": [\"scene0\", \"rays1\"]", "\"inputs\": [\"scene0\", \"rays0\"]"))
                .find("jobs[1].inputs: block 'rays0' (RayQueue) is consumed by use and already read by jobs[0]"),
            std::string::npos);
  // SceneData is copied, not consumed: any number of jobs may read it (every job here does).
  EXPECT_EQ(error_of(kGood), "");
}

namespace {
// The set planned and run to the end: GMB (k = 2 s), executed exactly as predicted.
RunStats run_to_completion(JobSet& set, Schedule& s) {
  for (auto [b, m] : set.initial) s.put_initial(b, m);
  GmbScheduler gmb({.horizon = 2.0});
  ExactExecutor ex(s);
  StaticWorkload wl;
  RuntimeLoop loop(gmb, ex, wl, set.pool, s);
  return loop.run();
}
}  // namespace

TEST(JobSet, PlannedSetProducesTraceCsvAndUtilisation) {
  const DeviceGraph g = two_node_graph();
  JobSet set = parse_job_set(kGood, "jobs.json", g);
  // A name the trace writer has to escape (RFC 8259 Sec. 7): quote, backslash, a control
  // character, and UTF-8 that passes through.
  const std::string odd = "ray \"q\" \\ 1\n\t\x01 \xc3\xa9";
  set.pool.job(0).name = odd;
  Schedule s(g, set.pool);
  const RunStats st = run_to_completion(set, s);
  ASSERT_FALSE(st.stalled);
  for (JobId j = 0; j < 3; ++j) EXPECT_EQ(set.pool.state(j), JobState::Done);
  const auto check = rayline::testing::check_schedule(s, set.pool);
  EXPECT_TRUE(check.errors.empty()) << check.errors.front();
  // Chrome trace: valid JSON, one complete event per E-job, one per T-job and resource.
  const auto trace = nlohmann::json::parse(chrome_trace_json(s, true));
  int execs = 0, transfers = 0, odd_named = 0;
  for (const auto& e : trace["traceEvents"]) {
    if (e["ph"] != "X") continue;
    const std::string cat = e["cat"];
    if (cat.starts_with("E-job")) ++execs;
    if (cat.starts_with("T-job")) ++transfers;
    // Times round-trip exactly (shortest round-trip digits).
    const Activity& a = s.activity(e["args"]["activity"].get<ActivityId>());
    const bool actual = cat.ends_with(",actual");
    EXPECT_EQ(e["ts"].get<double>(), (actual ? a.start : a.planned_start) * 1e6);
    EXPECT_EQ(e["dur"].get<double>(), ((actual ? a.end : a.planned_end) - (actual ? a.start : a.planned_start)) * 1e6);
    if (cat.starts_with("E-job")) {
      EXPECT_EQ(e["name"], set.pool.job(a.job).name);
      odd_named += e["name"] == odd;
    }
  }
  EXPECT_EQ(odd_named, 2);  // planned + actual
  EXPECT_EQ(execs, 6);  // 3 planned + 3 actual
  EXPECT_GT(transfers, 0);
  const std::string csv = jobs_csv(s);
  // RFC 4180 records: line breaks outside quotes; every record has the header's 13 fields.
  std::vector<int> fields{1};
  bool quoted = false;
  for (const char c : csv) {
    if (c == '"') quoted = !quoted;
    else if (!quoted && c == ',') ++fields.back();
    else if (!quoted && c == '\n') fields.push_back(1);
  }
  fields.pop_back();  // after the last line break
  EXPECT_EQ(fields.size(), s.activity_count() + 1);
  for (int f : fields) EXPECT_EQ(f, 13);
  EXPECT_NE(csv.find(",\"ray \"\"q\"\" \\ 1\n"), std::string::npos);  // the odd name, quoted
  EXPECT_NE(csv.find("n1.cpu0"), std::string::npos);
  // Time split adds up to the span on every device.
  const Utilisation u = compute_utilisation(s, 0, st.makespan);
  for (const DeviceTime& t : u.devices) EXPECT_NEAR(t.busy + t.setup + t.fetching + t.idle, st.makespan, 1e-9);
}

// A long run's trace is streamed in pieces (write_chrome_trace drains its buffer at 1 MiB),
// never held whole; the pieces concatenate to exactly the string form.
TEST(JobSet, LargeTraceIsStreamedInPiecesThatFormTheSameDocument) {
  struct CountingBuf : std::stringbuf {
    int writes = 0;
    std::streamsize xsputn(const char* p, std::streamsize n) override {
      ++writes;
      return std::stringbuf::xsputn(p, n);
    }
  };
  const DeviceGraph g = two_node_graph();
  JobSet set = synthetic_ray_batching(g, 16, 3000, 5);
  // Long names that need escaping make the trace large (a snapshot holds a few hundred jobs).
  for (JobId j = 0; j < static_cast<JobId>(set.pool.job_count()); ++j)
    set.pool.job(j).name = "job" + std::to_string(j) + " \"" + std::string(3000, 'x') + "\"";
  Schedule s(g, set.pool);
  ASSERT_FALSE(run_to_completion(set, s).stalled);
  const std::string whole = chrome_trace_json(s, true);
  ASSERT_GT(whole.size(), std::size_t{3} << 20) << s.activity_count() << " activities";  // several pieces
  CountingBuf buf;
  std::ostream out(&buf);
  write_chrome_trace(s, true, out);
  EXPECT_GE(buf.writes, 3);
  EXPECT_EQ(buf.str(), whole);
  const auto trace = nlohmann::json::parse(whole);
  std::size_t events = 0;
  for (const auto& e : trace["traceEvents"]) events += e["ph"] == "X";
  EXPECT_GE(events, 2 * s.activity_count() - 1);  // planned + actual of each (all done)
  std::ostringstream csv;
  write_jobs_csv(s, csv);
  EXPECT_EQ(csv.str(), jobs_csv(s));
}

TEST(JobSet, SyntheticIsDeterministicAndPlacesQueuesInHostMemory) {
  const DeviceGraph g = two_node_graph();
  const JobSet a = synthetic_ray_batching(g, 16, 100, 7), b = synthetic_ray_batching(g, 16, 100, 7),
               c = synthetic_ray_batching(g, 16, 100, 8);
  ASSERT_EQ(a.pool.block_count(), 116u);
  bool differs = false;
  for (std::size_t i = 0; i < a.pool.block_count(); ++i) {
    EXPECT_EQ(a.pool.block(static_cast<BlockId>(i)).bytes, b.pool.block(static_cast<BlockId>(i)).bytes);
    differs = differs || a.pool.block(static_cast<BlockId>(i)).bytes != c.pool.block(static_cast<BlockId>(i)).bytes;
  }
  EXPECT_TRUE(differs);
  for (auto [blk, m] : a.initial)
    EXPECT_EQ(g.memories[m].kind, a.pool.block(blk).kind == DataKind::SceneData ? MemoryKind::Disk : MemoryKind::Host);
}
