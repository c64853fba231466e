// Dynamic job prediction (Sec. 5.2, Fig. 6). For a (Shadow)RayIntersect-producing job J
// with |R| rays on block b, its future jobs are:
//   * no intersection: n_a = (1 - alpha_b)|R| rays to the neighbour cells, weight w_i by
//     the shared surface area (the paper: "relative ratio of the surface area");
//   * shadow rays:     n_b = alpha_b |R| ShadowIntersect rays on b;
//   * secondary rays:  n_c = alpha_b beta_b |R| RayIntersect rays on b.
// Fig. 3 puts a Shade job between RayIntersect and its shadow/secondary rays, so the
// predicted tree of a RayIntersect is: RayIntersect(n_i) per neighbour, and a Shade(b) of
// alpha|R| hits whose own predicted children are ShadowIntersect(b) and RayIntersect(b).
// alpha_b and beta_b are running averages of the outcomes observed on b (Sec. 5.2: "averaging
// the hit ratio over prior intersection results on the corresponding SceneData"), starting
// from the profile's analytic values.
//
// Predicted jobs are real JobPool jobs (Job::predicted_from = parent) whose RayQueue input
// is a placeholder output of the parent (so they can only run after it, on data it
// produces, and GMB can plan their fetches — the prefetch — before the parent ends).
// Recursion stops at `max_depth` intersect levels below a real job.
// When the parent ends, each child is resolved against the real outcome:
//   * real rays for it and the child is already planned: it is confirmed and will process
//     them (the workload gives it the real rays; its E-job runs for their real size);
//   * real rays but the child is still queued: it is superseded — discarded with its
//     subtree, and the rays become an ordinary (merged or new) job;
//   * no rays: it failed — discarded with its subtree. If queued, the jobs leave the pool;
//     if planned, the whole planned subtree fails at once and is listed (deepest first) by
//     take_failed_planned(), for the workload to withdraw their E-jobs and T-jobs from the
//     Schedule (Schedule::cancel_job: the paper's "discarded with their T-jobs").
// Placeholders are not "consumed" blocks: a leftover placeholder is plain cache that the
// Schedule may evict once no queued job wants it (its size never changes after commit).
#pragma once
#include <functional>
#include <utility>
#include <vector>

#include "sched/core/job_pool.hpp"
#include "workload/path_trace_graph.hpp"
#include "workload/scene_profile.hpp"

namespace rayline {

struct PredictionStats {
  std::uint64_t created = 0;            // predicted jobs added to the pool
  std::uint64_t confirmed = 0;          // resolved: the parent produced rays for it
  std::uint64_t confirmed_planned = 0;  //   ... and it was already planned (the prefetch paid off)
  std::uint64_t failed = 0;             // resolved: no rays for it (incl. subtrees of failed jobs)
  std::uint64_t superseded = 0;         // descendants of a confirmed-but-unplanned job (not judged)
  double ray_min = 0, ray_max = 0;      // sums over resolved jobs of min/max(predicted, actual)
  // Accuracy (README/docs): confirmed / (confirmed + failed); ray accuracy: ray_min / ray_max.
  double accuracy() const {
    const double n = static_cast<double>(confirmed + failed);
    return n > 0 ? static_cast<double>(confirmed) / n : 0.0;
  }
  double ray_accuracy() const { return ray_max > 0 ? ray_min / ray_max : 0.0; }
};

class JobPredictor {
 public:
  // Builds the E-job for a predicted child: its inputs (SceneData + `queue`), type, work.
  using MakeJob = std::function<Job(PtJob kind, int block, BlockId queue, double rays)>;
  // Adds a placeholder queue block (the parent's output) for a predicted child.
  using MakeBlock = std::function<BlockId(PtJob kind, int block, double rays)>;

  JobPredictor(const SceneProfile& profile, int max_depth, MakeJob make_job, MakeBlock make_block);
  int max_depth() const { return max_depth_; }

  // Sec. 5.2 estimates, updated from every real outcome.
  void observe_intersect(int block, std::uint64_t rays, std::uint64_t hits);
  void observe_shade(int block, std::uint64_t hits, std::uint64_t survived);
  double alpha(int block) const;
  double beta(int block) const;

  // Adds `job` (a real job of `kind` on `block` with `rays`) to the pool with the
  // placeholder outputs of its predicted children, then the children, recursively.
  JobId add(Job job, PtJob kind, int block, double rays, JobPool& pool);
  // More rays merged into the queued job j (Sec. 5.1): its predicted subtree grows alike.
  void rescale(JobId j, double factor, JobPool& pool);

  bool is_predicted(JobId j) const {
    return j >= 0 && static_cast<std::size_t>(j) < nodes_.size() && nodes_[static_cast<std::size_t>(j)].predicted;
  }
  // The real outcome of `parent` for (kind, block): `actual` rays. Returns the planned
  // predicted child that takes those rays (kNone: route them as an ordinary job).
  JobId resolve(JobId parent, PtJob kind, int block, std::uint64_t actual, JobPool& pool);
  // After the parent's outcomes were resolved: children it produced nothing for failed.
  void finish(JobId parent, JobPool& pool);
  // Planned predicted jobs judged failed since the last call, every job after its
  // descendants (so each one's outputs are unused when it is withdrawn).
  std::vector<JobId> take_failed_planned() { return std::exchange(failed_planned_, {}); }
  double predicted_rays(JobId j) const { return nodes_[static_cast<std::size_t>(j)].rays; }
  PtJob kind(JobId j) const { return nodes_[static_cast<std::size_t>(j)].kind; }
  int block(JobId j) const { return nodes_[static_cast<std::size_t>(j)].block; }
  BlockId placeholder(JobId j) const { return nodes_[static_cast<std::size_t>(j)].placeholder; }
  const std::vector<JobId>& children(JobId j) const;  // empty for jobs it never saw

  const PredictionStats& stats() const { return stats_; }

 private:
  struct Node {
    bool predicted = false;
    bool resolved = false;
    PtJob kind = PtJob::Intersect;
    int block = 0, level = 0;
    double rays = 0;
    BlockId placeholder = kNone;  // input queue (predicted jobs)
    std::vector<JobId> children;
  };
  struct Spec {
    PtJob kind;
    int block, level;
    double rays;
  };
  void children_of(const Node& n, std::vector<Spec>& out) const;
  JobId add_node(Job job, Node node, JobPool& pool);
  void discard(JobId j, JobPool& pool, bool judged_failed);
  void fail_planned(JobId j, JobPool& pool);
  Node& node(JobId j);

  const SceneProfile& profile_;
  int max_depth_;
  MakeJob make_job_;
  MakeBlock make_block_;
  std::vector<double> hits_, rays_, survived_, shaded_;  // per block, observed
  std::vector<Node> nodes_;                              // per JobId (real jobs too)
  PredictionStats stats_;
  std::vector<JobId> failed_planned_;
};

}  // namespace rayline
