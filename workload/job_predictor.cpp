#include "workload/job_predictor.hpp"

#include <algorithm>

namespace rayline {

namespace {
constexpr double kPriorRays = 10000;    // weight of the profile's analytic alpha/beta before observations
constexpr double kMinPredictedRays = 16;  // smaller predicted queues are not worth a job
}  // namespace

JobPredictor::JobPredictor(const SceneProfile& profile, int max_depth, MakeJob make_job, MakeBlock make_block)
    : profile_(profile),
      max_depth_(max_depth),
      make_job_(std::move(make_job)),
      make_block_(std::move(make_block)),
      hits_(profile.blocks.size(), 0),
      rays_(profile.blocks.size(), 0),
      survived_(profile.blocks.size(), 0),
      shaded_(profile.blocks.size(), 0) {}

void JobPredictor::observe_intersect(int b, std::uint64_t rays, std::uint64_t hits) {
  rays_[static_cast<std::size_t>(b)] += static_cast<double>(rays);
  hits_[static_cast<std::size_t>(b)] += static_cast<double>(hits);
}

void JobPredictor::observe_shade(int b, std::uint64_t hits, std::uint64_t survived) {
  shaded_[static_cast<std::size_t>(b)] += static_cast<double>(hits);
  survived_[static_cast<std::size_t>(b)] += static_cast<double>(survived);
}

double JobPredictor::alpha(int b) const {
  const auto i = static_cast<std::size_t>(b);
  return (profile_.analytic.alpha * kPriorRays + hits_[i]) / (kPriorRays + rays_[i]);
}

double JobPredictor::beta(int b) const {
  const auto i = static_cast<std::size_t>(b);
  return (profile_.analytic.beta * kPriorRays + survived_[i]) / (kPriorRays + shaded_[i]);
}

JobPredictor::Node& JobPredictor::node(JobId j) {
  if (static_cast<std::size_t>(j) >= nodes_.size()) nodes_.resize(static_cast<std::size_t>(j) + 1);
  return nodes_[static_cast<std::size_t>(j)];
}

// Sec. 5.2's three cases, one intersect level deeper; Shade carries the shadow and
// secondary rays of a predicted RayIntersect (Fig. 3) without a level of its own.
void JobPredictor::children_of(const Node& n, std::vector<Spec>& out) const {
  out.clear();
  if (n.kind == PtJob::Intersect) {
    const int next = n.level + 1;
    if (next > max_depth_) return;
    const ProfileBlock& blk = profile_.blocks[static_cast<std::size_t>(n.block)];
    const double a = alpha(n.block);
    const double miss = (1 - a) * n.rays;  // n_a
    double area = 0;
    for (const ProfileNeighbour& x : blk.neighbours) area += x.area;
    for (const ProfileNeighbour& x : blk.neighbours) {
      const double w = area > 0 ? x.area / area : 1.0 / static_cast<double>(blk.neighbours.size());
      if (w * miss >= kMinPredictedRays) out.push_back({PtJob::Intersect, x.block, next, w * miss});
    }
    if (a * n.rays >= kMinPredictedRays) out.push_back({PtJob::Shade, n.block, next, a * n.rays});
  } else if (n.kind == PtJob::Shade) {
    const int level = n.predicted ? n.level : n.level + 1;
    if (level > max_depth_) return;
    if (n.rays >= kMinPredictedRays) out.push_back({PtJob::Shadow, n.block, level, n.rays});            // n_b
    const double c = beta(n.block) * n.rays;                                                            // n_c
    if (c >= kMinPredictedRays) out.push_back({PtJob::Intersect, n.block, level, c});
  }
}

JobId JobPredictor::add_node(Job job, Node n, JobPool& pool) {
  std::vector<Spec> specs;
  children_of(n, specs);
  std::vector<BlockId> holders;
  for (const Spec& s : specs) {
    holders.push_back(make_block_(s.kind, s.block, s.rays));
    job.outputs.push_back(holders.back());
  }
  const JobId id = pool.add_job(std::move(job));
  if (n.predicted) ++stats_.created;
  node(id) = n;
  for (std::size_t i = 0; i < specs.size(); ++i) {
    const Spec& s = specs[i];
    Job child = make_job_(s.kind, s.block, holders[i], s.rays);
    child.predicted_from = id;
    Node cn;
    cn.predicted = true;
    cn.kind = s.kind;
    cn.block = s.block;
    cn.level = s.level;
    cn.rays = s.rays;
    cn.placeholder = holders[i];
    const JobId c = add_node(std::move(child), cn, pool);
    node(id).children.push_back(c);
  }
  return id;
}

JobId JobPredictor::add(Job job, PtJob kind, int block, double rays, JobPool& pool) {
  Node n;
  n.kind = kind;
  n.block = block;
  n.rays = rays;
  return add_node(std::move(job), n, pool);
}

void JobPredictor::rescale(JobId j, double factor, JobPool& pool) {
  for (JobId c : node(j).children) {
    Node& n = node(c);
    n.rays *= factor;
    const Bytes per = n.kind == PtJob::Shadow ? profile_.shadow_ray_bytes
                      : n.kind == PtJob::Shade ? profile_.hit_bytes
                                               : profile_.ray_bytes;
    pool.block(n.placeholder).bytes = std::max<Bytes>(1, static_cast<Bytes>(n.rays * static_cast<double>(per)));
    if (pt_traces_rays(n.kind)) pool.job(c).work = static_cast<std::uint64_t>(n.rays);
    rescale(c, factor, pool);
  }
}

void JobPredictor::discard(JobId j, JobPool& pool, bool judged_failed) {
  Node& n = node(j);
  if (!n.resolved) {
    n.resolved = true;
    if (judged_failed) ++stats_.failed;
    else ++stats_.superseded;
  }
  if (pool.state(j) == JobState::Queued) pool.mark_discarded(j);
  const std::vector<JobId> kids = n.children;
  for (JobId c : kids) discard(c, pool, judged_failed);
}

JobId JobPredictor::resolve(JobId parent, PtJob kind, int block, std::uint64_t actual, JobPool& pool) {
  if (static_cast<std::size_t>(parent) >= nodes_.size()) return kNone;
  JobId c = kNone;
  for (JobId x : nodes_[static_cast<std::size_t>(parent)].children) {
    const Node& n = nodes_[static_cast<std::size_t>(x)];
    if (!n.resolved && n.kind == kind && n.block == block) {
      c = x;
      break;
    }
  }
  if (c == kNone) return kNone;
  Node& n = node(c);
  n.resolved = true;
  const double a = static_cast<double>(actual);
  stats_.ray_min += std::min(a, n.rays);
  stats_.ray_max += std::max(a, n.rays);
  const bool planned = pool.state(c) == JobState::Planned || pool.state(c) == JobState::Done;
  if (actual > 0) {
    ++stats_.confirmed;
    if (planned) {
      ++stats_.confirmed_planned;
      return c;
    }
    pool.mark_discarded(c);  // superseded by an ordinary job with the real rays
    for (JobId k : std::vector<JobId>(n.children)) discard(k, pool, false);
    return kNone;
  }
  ++stats_.failed;
  if (planned) {  // no rays will come to it nor below it: its planned subtree is withdrawn
    fail_planned(c, pool);
    return c;
  }
  pool.mark_discarded(c);
  for (JobId k : std::vector<JobId>(n.children)) discard(k, pool, true);
  return kNone;
}

void JobPredictor::fail_planned(JobId j, JobPool& pool) {
  for (JobId k : std::vector<JobId>(node(j).children)) {
    Node& n = node(k);
    if (n.resolved) continue;
    if (pool.state(k) == JobState::Planned) {
      n.resolved = true;
      ++stats_.failed;
      fail_planned(k, pool);
    } else {
      discard(k, pool, true);
    }
  }
  failed_planned_.push_back(j);
}

const std::vector<JobId>& JobPredictor::children(JobId j) const {
  static const std::vector<JobId> kNoChildren;
  return j >= 0 && static_cast<std::size_t>(j) < nodes_.size() ? nodes_[static_cast<std::size_t>(j)].children : kNoChildren;
}

void JobPredictor::finish(JobId parent, JobPool& pool) {
  if (static_cast<std::size_t>(parent) >= nodes_.size()) return;
  const std::vector<JobId> kids = nodes_[static_cast<std::size_t>(parent)].children;
  for (JobId c : kids)
    if (!nodes_[static_cast<std::size_t>(c)].resolved) resolve(parent, nodes_[static_cast<std::size_t>(c)].kind, nodes_[static_cast<std::size_t>(c)].block, 0, pool);
}

}  // namespace rayline
