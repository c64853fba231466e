// Job prediction (Sec. 5.2) in isolation: the predicted tree of a RayIntersect follows the
// paper's n_a, n_b, n_c with area weights; children link to their parent; a prediction is
// confirmed when rays come, fails (and is discarded with its subtree) when none do.
#include <gtest/gtest.h>

#include "workload/job_predictor.hpp"

using namespace rayline;

namespace {
SceneProfile line3() {  // blocks 0 - 1 - 2 in a row; block 1 has two neighbours, areas 1 and 3
  SceneProfile p;
  p.analytic.alpha = 0.5;
  p.analytic.beta = 0.5;
  p.blocks.resize(3);
  p.blocks[0].neighbours = {{1, 1.0, 1.0}};
  p.blocks[1].neighbours = {{0, 1.0, 0.25}, {2, 3.0, 0.75}};
  p.blocks[2].neighbours = {{1, 3.0, 1.0}};
  return p;
}

struct Fixture {
  SceneProfile prof = line3();
  JobPool pool;
  JobPredictor pred;
  explicit Fixture(int depth)
      : pred(prof, depth,
             [](PtJob k, int b, BlockId q, double rays) {
               Job j;
               j.name = std::string(kPtJobTypeNames[static_cast<int>(k)]) + std::to_string(b);
               j.inputs = {q};
               j.work = static_cast<std::uint64_t>(rays);
               return j;
             },
             [this](PtJob k, int, double rays) {
               DataBlock d;
               d.kind = pt_queue_kind(k);
               d.bytes = static_cast<Bytes>(rays * 64);
               return pool.add_block(d);
             }) {}
  // The predicted child of `parent` of this kind on this block (kNone if there is none).
  JobId child(JobId parent, PtJob kind, int block) const {
    for (JobId c : pred.children(parent))
      if (pred.kind(c) == kind && pred.block(c) == block) return c;
    return kNone;
  }
};
}  // namespace

TEST(JobPredictor, TreeFollowsSec52) {
  Fixture f(1);
  Job j;
  j.name = "real";
  const JobId r = f.pred.add(j, PtJob::Intersect, 1, 100000, f.pool);
  // n_a = 50000 misses: 12500 to block 0 (area 1/4), 37500 to block 2; Shade of 50000 hits
  // with n_b = 50000 shadow rays and n_c = 25000 secondary rays.
  ASSERT_EQ(f.pred.children(r).size(), 3u);
  EXPECT_EQ(f.pool.job(r).outputs.size(), 3u);
  std::map<std::pair<int, int>, double> got;
  for (JobId c : f.pred.children(r)) {
    EXPECT_EQ(f.pool.job(c).predicted_from, r);
    EXPECT_TRUE(f.pred.is_predicted(c));
    got[{static_cast<int>(f.pred.kind(c)), f.pred.block(c)}] = f.pred.predicted_rays(c);
  }
  EXPECT_DOUBLE_EQ((got[{static_cast<int>(PtJob::Intersect), 0}]), 12500);
  EXPECT_DOUBLE_EQ((got[{static_cast<int>(PtJob::Intersect), 2}]), 37500);
  EXPECT_DOUBLE_EQ((got[{static_cast<int>(PtJob::Shade), 1}]), 50000);
  JobId shade = kNone;
  for (JobId c : f.pred.children(r))
    if (f.pred.kind(c) == PtJob::Shade) shade = c;
  ASSERT_EQ(f.pred.children(shade).size(), 2u);  // Shade carries n_b and n_c at the same level
  EXPECT_EQ(f.pred.stats().created, 5u);
}

TEST(JobPredictor, DepthLimitsRecursion) {
  Fixture f1(1), f2(2);
  Job j;
  f1.pred.add(j, PtJob::Intersect, 1, 100000, f1.pool);
  f2.pred.add(j, PtJob::Intersect, 1, 100000, f2.pool);
  EXPECT_GT(f2.pred.stats().created, f1.pred.stats().created);
}

TEST(JobPredictor, QueuedMissIsDiscardedWithItsSubtree) {
  Fixture f(2);
  Job j;
  const JobId r = f.pred.add(j, PtJob::Intersect, 1, 100000, f.pool);
  const std::size_t queued = f.pool.queued_count();
  // Block 0 got no rays: that child and everything predicted below it are discarded.
  EXPECT_EQ(f.pred.resolve(r, PtJob::Intersect, 0, 0, f.pool), kNone);
  EXPECT_LT(f.pool.queued_count(), queued);
  EXPECT_GT(f.pred.stats().failed, 1u);
  EXPECT_EQ(f.pred.stats().confirmed, 0u);
  // Rays for block 2 while its predicted job is still queued: confirmed, but superseded by
  // an ordinary job (returns kNone), its own subtree not judged.
  EXPECT_EQ(f.pred.resolve(r, PtJob::Intersect, 2, 30000, f.pool), kNone);
  EXPECT_EQ(f.pred.stats().confirmed, 1u);
  EXPECT_GT(f.pred.stats().superseded, 0u);
  f.pred.finish(r, f.pool);  // the Shade child had no outcome reported: failed
  EXPECT_NEAR(f.pred.stats().accuracy(), 1.0 / (1.0 + static_cast<double>(f.pred.stats().failed)), 1e-12);
}

TEST(JobPredictor, PlannedChildTakesTheRealRays) {
  Fixture f(1);
  Job j;
  const JobId r = f.pred.add(j, PtJob::Intersect, 1, 100000, f.pool);
  const JobId c2 = f.child(r, PtJob::Intersect, 2);
  f.pool.mark_planned(r, 0);
  f.pool.mark_planned(c2, 1);
  EXPECT_EQ(f.pred.resolve(r, PtJob::Intersect, 2, 40000, f.pool), c2);
  EXPECT_EQ(f.pred.stats().confirmed_planned, 1u);
  EXPECT_DOUBLE_EQ(f.pred.stats().ray_accuracy(), 37500.0 / 40000.0);
}

TEST(JobPredictor, EstimatesAverageObservedOutcomes) {
  Fixture f(1);
  EXPECT_DOUBLE_EQ(f.pred.alpha(0), 0.5);
  f.pred.observe_intersect(0, 1000000, 900000);
  EXPECT_NEAR(f.pred.alpha(0), 0.9, 0.01);
  f.pred.observe_shade(0, 1000000, 100000);
  EXPECT_NEAR(f.pred.beta(0), 0.1, 0.01);
}

TEST(JobPredictor, PlannedMissFailsItsPlannedSubtreeDeepestFirst) {
  Fixture f(2);
  Job j;
  const JobId r = f.pred.add(j, PtJob::Intersect, 1, 100000, f.pool);
  const JobId c2 = f.child(r, PtJob::Intersect, 2);
  ASSERT_NE(c2, kNone);
  ASSERT_FALSE(f.pred.children(c2).empty());
  f.pool.mark_planned(r, 0);
  f.pool.mark_planned(c2, 1);
  const JobId g = f.pred.children(c2).front();  // planned too; its siblings stay queued
  f.pool.mark_planned(g, 2);
  const std::size_t failed_before = f.pred.stats().failed;
  EXPECT_EQ(f.pred.resolve(r, PtJob::Intersect, 2, 0, f.pool), c2);  // no rays: failed, planned
  const std::vector<JobId> gone = f.pred.take_failed_planned();
  ASSERT_GE(gone.size(), 2u);
  EXPECT_EQ(gone.back(), c2) << "the job comes after its descendants";
  EXPECT_NE(std::find(gone.begin(), gone.end(), g), gone.end());
  EXPECT_LT(std::find(gone.begin(), gone.end(), g) - gone.begin(), static_cast<std::ptrdiff_t>(gone.size() - 1));
  // Every descendant was judged now: failed, queued ones discarded.
  for (JobId k : f.pred.children(c2))
    if (k != g) {
      EXPECT_EQ(f.pool.state(k), JobState::Discarded);
    }
  EXPECT_GE(f.pred.stats().failed - failed_before, 1 + f.pred.children(c2).size());
  EXPECT_TRUE(f.pred.take_failed_planned().empty());
}
