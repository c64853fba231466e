// The RAM side of the disk->RAM channel: BlockStore loads and evictions, the
// read-ahead that overlaps a block's read with the previous build, the ArrayPool that
// recycles evicted blocks' arrays, and LocalExecutor's hints that start read-aheads.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <random>
#include <string>
#include <thread>
#include <unistd.h>
#include <vector>

#include "render/store/block_store.hpp"
#include "render/engine/local_executor.hpp"
#include "render/partition/partition.hpp"
#include "render/embree/array_pool.hpp"
#include "common/error.hpp"

namespace fs = std::filesystem;
using namespace rayline;
using engine::BlockStore;
using partition::Triangle;

namespace {

// A partition of a random triangle soup into `blocks` blocks in a temporary folder.
class BlockStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("rayline-store-" + std::string(info->name()) + "-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    auto source = [](const scene::TriangleBatchFn& fn) {
      std::mt19937 rng(3);
      std::uniform_real_distribution<float> u(0, 1);
      std::vector<Triangle> batch;
      scene::ImportStats st;
      for (int i = 0; i < 6000; ++i) {
        Triangle t;
        const partition::Float3 c{u(rng) * 8, u(rng) * 8, u(rng) * 8};
        t.v0 = c, t.v1 = {c.x + 0.1f, c.y, c.z}, t.v2 = {c.x, c.y + 0.1f, c.z};
        t.material = 0;
        st.bounds.extend(t.v0), st.bounds.extend(t.v1), st.bounds.extend(t.v2);
        batch.push_back(t);
      }
      fn(batch);
      st.triangles = batch.size();
      return st;
    };
    partition::PartitionOptions o;
    o.blocks = 4;
    o.memory_limit = 16 << 20;
    index_ = partition::partition_triangles(source, "soup", dir_.string(), o).index;
    for (const auto& b : index_.blocks) footprint_.push_back(BlockStore::footprint_of(b.triangles, trace::BvhQuality::Low));
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::unique_ptr<BlockStore> store() const {
    return std::make_unique<BlockStore>(index_, dir_.string(), footprint_, 1, trace::BvhQuality::Low, 1);
  }
  fs::path dir_;
  partition::BlockIndex index_;
  std::vector<std::uint64_t> footprint_;
};

}  // namespace

TEST(ArrayPool, RecyclesArraysOfAboutTheSameSizeOnly) {
  constexpr std::size_t K = 100000;
  trace::ArrayPool pool(1, 2);
  std::vector<float> a = pool.floats(10 * K);
  ASSERT_EQ(a.size(), 10 * K);
  const float* first = a.data();
  pool.give(std::move(a));
  EXPECT_EQ(pool.reuses(), 0u);
  std::vector<float> b = pool.floats(95 * K / 10);  // within 1/8: the same storage comes back
  EXPECT_EQ(b.data(), first);
  EXPECT_EQ(b.size(), 95 * K / 10);
  EXPECT_EQ(pool.reuses(), 1u);
  pool.give(std::move(b));
  std::vector<float> c = pool.floats(K);  // far smaller: a fresh array (bounded slack)
  EXPECT_NE(c.data(), first);
  EXPECT_EQ(pool.reuses(), 1u);
  std::vector<float> d = pool.floats(20 * K);  // larger than any idle one: fresh
  EXPECT_EQ(pool.reuses(), 1u);
  // keep = 1 float array: of the three given, the largest stays.
  pool.give(std::move(d));
  pool.give(std::move(c));
  EXPECT_EQ(pool.idle_bytes(), 20 * K * sizeof(float));
  // uints: keep = 2, the larger ones.
  for (std::size_t i = 0; i < 3; ++i) pool.give(std::vector<std::uint32_t>(K + i));
  EXPECT_EQ(pool.idle_bytes(), 20 * K * sizeof(float) + (2 * K + 3) * sizeof(std::uint32_t));
  EXPECT_EQ(pool.uints(K + 1).size(), K + 1);
  EXPECT_EQ(pool.reuses(), 2u);
}

TEST_F(BlockStoreTest, ReadAheadServesTheLoadAndGivesTheSameGeometry) {
  auto direct = store();
  auto ahead = store();
  for (std::uint32_t b = 0; b < index_.blocks.size(); ++b) {
    ahead->read_ahead(b);
    ahead->read_ahead(b);  // a second hint for the same block reads nothing more
    ahead->load(b);
    direct->load(b);
    const auto ga = ahead->get(b), gd = direct->get(b);
    ASSERT_EQ(ga->triangles(), gd->triangles());
    for (std::uint32_t p = 0; p < ga->triangles(); ++p)
      for (int k = 0; k < 3; ++k) ASSERT_EQ(ga->vertex(p, k).x, gd->vertex(p, k).x);
  }
  const auto sa = ahead->stats(), sd = direct->stats();
  EXPECT_EQ(sa.loads, index_.blocks.size());
  EXPECT_EQ(sa.read_aheads, index_.blocks.size());
  EXPECT_EQ(sa.wasted_read_aheads, 0u);
  EXPECT_EQ(sd.read_aheads, 0u);
  EXPECT_EQ(sa.bytes_read, sd.bytes_read);
  EXPECT_EQ(sa.unplanned_loads, 0u);
  EXPECT_GT(sa.channel_busy_seconds, 0.0);
  EXPECT_GE(sa.channel_busy_seconds + 1e-9, sa.disk_read_busy_seconds);
}

TEST_F(BlockStoreTest, OneStagedReadPerLoader) {
  auto s = store();
  s->set_staging_slots(2);
  s->read_ahead(0);
  s->read_ahead(1);  // two loaders: both stay staged
  s->read_ahead(2);  // a third replaces the oldest (block 0)
  s->load(1);
  s->load(2);
  s->load(0);  // read directly
  const auto st = s->stats();
  EXPECT_EQ(st.loads, 3u);
  EXPECT_EQ(st.read_aheads, 2u);
  EXPECT_EQ(st.wasted_read_aheads, 1u);
  EXPECT_LE(st.worst_footprint_ratio, 1.0);
}

TEST_F(BlockStoreTest, ReadAheadOfAResidentBlockOrAnotherBlockIsNotUsed) {
  auto s = store();
  s->load(0);
  s->read_ahead(0);  // resident: nothing to read
  s->read_ahead(1);
  s->read_ahead(2);  // replaces the unused read of block 1
  s->load(1);        // reads directly
  s->load(2);        // from the read-ahead
  const auto st = s->stats();
  EXPECT_EQ(st.loads, 3u);
  EXPECT_EQ(st.read_aheads, 1u);
  EXPECT_EQ(st.wasted_read_aheads, 1u);
  s->read_ahead(3);  // still in flight or staged when the store goes: no crash, no leak
}

TEST_F(BlockStoreTest, EvictedArraysAreRecycledByTheNextLoad) {
  auto s = store();
  s->load(0);
  s->evict(0);
  s->load(0);  // the same block: its own arrays come back
  EXPECT_GE(s->stats().recycled_arrays, 3u);  // vertices, indices, materials
  EXPECT_LE(s->stats().worst_footprint_ratio, 1.0);
}

TEST_F(BlockStoreTest, CorruptedBlockReadAheadIsAnInputErrorAtLoad) {
  const std::string file = (dir_ / index_.blocks[1].file).string();
  {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(200);
    const char junk[4] = {1, 2, 3, 4};
    f.write(junk, 4);
  }
  auto s = store();
  s->read_ahead(1);
  try {
    s->load(1);
    FAIL() << "a corrupted block must not load";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("payload_crc32"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(index_.blocks[1].file), std::string::npos) << e.what();
  }
}

TEST(LocalExecutorHints, EachHintRunsOnceBeforeItsTaskWhileThePreviousOneRuns) {
  // One CPU device: three activities in one lane, each with a hint.
  DeviceGraph g;
  Node node;
  node.name = "n";
  g.nodes.push_back(node);
  MemoryDevice m;
  m.name = "ram";
  m.kind = MemoryKind::Host;
  m.capacity = 1 << 20;
  g.memories.push_back(m);
  ComputeDevice c;
  c.name = "cpu";
  c.memory = 0;
  g.computes.push_back(c);
  std::mutex mu;
  std::vector<std::string> log;
  auto note = [&](const std::string& s) {
    std::lock_guard lk(mu);
    log.push_back(s);
  };
  std::atomic<bool> release{false};
  engine::LocalExecutor ex(
      g,
      [&](ActivityId id, const Activity&) -> engine::LocalExecutor::Task {
        return [&, id] {
          note("run" + std::to_string(id));
          // The hint of 1 must come while 0 runs (bounded wait: a missing hint fails below).
          const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
          if (id == 0)
            while (!release && std::chrono::steady_clock::now() < until) std::this_thread::yield();
        };
      },
      [&](ActivityId id, const Activity&) -> engine::LocalExecutor::Task {
        return [&, id] {
          note("hint" + std::to_string(id));
          if (id == 1) release = true;
        };
      });
  for (ActivityId id = 0; id < 3; ++id) {
    Activity a;
    a.kind = ActivityKind::Exec;
    a.device = 0;
    if (id > 0) a.timeline_prev = {id - 1};
    ex.dispatch(id, a);
  }
  std::vector<ExecutorEvent> ev;
  while (ex.advance(ev)) {
  }
  ASSERT_EQ(log.size(), 6u);
  EXPECT_TRUE(release.load()) << "the next activity's hint must run while its predecessor runs";
  auto at = [&](const std::string& s) { return std::find(log.begin(), log.end(), s) - log.begin(); };
  for (int i = 0; i < 3; ++i) {
    const std::string k = std::to_string(i);
    EXPECT_EQ(std::count(log.begin(), log.end(), "hint" + k), 1) << "each hint runs exactly once";
    EXPECT_LT(at("hint" + k), at("run" + k)) << "a hint runs before its task";
  }
}

TEST(LocalExecutorHints, AFailureLeavesNoHintSpinning) {
  // Task 0 fails; the hints of the activities queued behind it are dropped, not run, and
  // the executor still drains (it used to spin on a hint it refused to run).
  DeviceGraph g;
  Node node;
  node.name = "n";
  g.nodes.push_back(node);
  MemoryDevice m;
  m.name = "ram";
  g.memories.push_back(m);
  ComputeDevice c;
  c.name = "cpu";
  c.memory = 0;
  g.computes.push_back(c);
  std::atomic<int> hints{0}, runs{0};
  engine::LocalExecutor ex(
      g,
      [&](ActivityId id, const Activity&) -> engine::LocalExecutor::Task {
        return [&, id] {
          ++runs;
          if (id == 0) throw std::runtime_error("load failed");
        };
      },
      [&](ActivityId, const Activity&) -> engine::LocalExecutor::Task { return [&] { ++hints; }; });
  Activity a;
  a.kind = ActivityKind::Exec;
  a.device = 0;
  ex.dispatch(0, a);
  std::vector<ExecutorEvent> ev;
  while (ex.advance(ev)) {
  }
  for (ActivityId id = 1; id < 4; ++id) {
    a.timeline_prev = {id - 1};
    ex.dispatch(id, a);
  }
  while (ex.advance(ev)) {
  }
  EXPECT_TRUE(ex.failure() != nullptr);
  EXPECT_EQ(runs.load(), 1) << "nothing runs after a failure";
  EXPECT_EQ(hints.load(), 1) << "only the first activity's hint ran";
  EXPECT_EQ(std::count_if(ev.begin(), ev.end(), [](const ExecutorEvent& e) { return e.type == ExecutorEvent::Type::Failed; }), 4);
}
