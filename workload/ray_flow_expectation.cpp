#include "workload/ray_flow_expectation.hpp"

#include <Eigen/Dense>
#include <numeric>
#include <stdexcept>

namespace rayline {

double RayFlowExpectation::block_visits() const {
  return std::accumulate(intersect.begin(), intersect.end(), 0.0) + std::accumulate(shadow.begin(), shadow.end(), 0.0);
}

namespace {

using Matrix = Eigen::MatrixXd;
using Vector = Eigen::VectorXd;

// Row-stochastic-minus-absorption matrix of a chain stage: [b][neighbour] = P(move there).
Matrix neighbour_moves(const SceneProfile& p, const RayFlowModel& model, RayStage stage) {
  const auto n = static_cast<Eigen::Index>(p.blocks.size());
  Matrix m = Matrix::Zero(n, n);
  std::vector<double> pr;
  for (Eigen::Index b = 0; b < n; ++b) {
    SplitContext ctx;
    ctx.stage = stage;
    ctx.block = static_cast<int>(b);
    model.probabilities(ctx, pr);
    const auto& nb = p.blocks[static_cast<std::size_t>(b)].neighbours;
    for (std::size_t i = 0; i < nb.size(); ++i) m(b, nb[i].block) += pr[static_cast<std::size_t>(kFirstNeighbour) + i];
  }
  return m;
}

// Solves v (I - M) = x for the row vector v, i.e. (I - M)^T v^T = x^T.
class ChainSolver {
 public:
  ChainSolver(const Matrix& moves, const char* what) {
    const Matrix a = (Matrix::Identity(moves.rows(), moves.cols()) - moves).transpose();
    lu_ = a.fullPivLu();
    if (!lu_.isInvertible())
      throw std::invalid_argument(std::string("scene profile: the ") + what + " chain never leaves the scene");
  }
  Vector visits(const Vector& entering) const { return lu_.solve(entering); }

 private:
  Eigen::FullPivLU<Matrix> lu_;
};

}  // namespace

RayFlowExpectation expected_ray_flow(const SceneProfile& p, Fidelity fidelity) {
  const RayFlowModel model(p, fidelity == Fidelity::Replay ? Fidelity::Markov : fidelity, 1);
  const auto n = static_cast<Eigen::Index>(p.blocks.size());
  const ChainSolver rays(neighbour_moves(p, model, RayStage::Intersect), "ray");
  const ChainSolver shadows(neighbour_moves(p, model, RayStage::Shadow), "shadow-ray");

  // Bounce 0: where camera rays enter, averaged over the camera path's keyframes.
  Vector x = Vector::Zero(n);
  std::vector<double> pr;
  for (std::size_t k = 0; k < p.camera_path.size(); ++k) {
    SplitContext ctx;
    ctx.stage = RayStage::Entry;
    ctx.block = static_cast<int>(k);
    model.probabilities(ctx, pr);
    for (Eigen::Index b = 0; b < n; ++b) x(b) += pr[1 + static_cast<std::size_t>(b)];
  }
  if (!p.camera_path.empty()) x /= static_cast<double>(p.camera_path.size());

  Vector alpha(n);
  for (Eigen::Index b = 0; b < n; ++b) {
    SplitContext ctx;
    ctx.stage = RayStage::Intersect;
    ctx.block = static_cast<int>(b);
    model.probabilities(ctx, pr);
    alpha(b) = pr[kHit];
  }

  RayFlowExpectation e;
  Vector intersect = Vector::Zero(n), shade = Vector::Zero(n), shadow = Vector::Zero(n);
  for (int bounce = 0; bounce < p.max_bounces && x.sum() > 0; ++bounce) {
    const Vector v = rays.visits(x);
    const Vector h = v.cwiseProduct(alpha);
    intersect += v;
    shade += h;
    shadow += shadows.visits(h);
    e.shadow_rays += h.sum();
    Vector next(n);
    for (Eigen::Index b = 0; b < n; ++b) {
      SplitContext ctx;
      ctx.stage = RayStage::Shade;
      ctx.block = static_cast<int>(b);
      ctx.bounce = bounce;
      model.probabilities(ctx, pr);
      next(b) = h(b) * pr[kSurvive];
    }
    e.secondary += next.sum();
    x = next;
  }
  e.intersect.assign(intersect.data(), intersect.data() + n);
  e.shade.assign(shade.data(), shade.data() + n);
  e.shadow.assign(shadow.data(), shadow.data() + n);
  return e;
}

}  // namespace rayline
