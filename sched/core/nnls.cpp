// Lawson-Hanson NNLS (Lawson & Hanson 1974, Algorithm 23.10); see nnls.hpp.
#include "sched/core/nnls.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>

namespace rayline {

NnlsResult solve_nnls(std::span<const double> a, int rows, int cols, std::span<const double> t) {
  NnlsResult res;
  if (rows < cols || cols <= 0 || a.size() != std::size_t(rows) * std::size_t(cols) || t.size() != std::size_t(rows))
    return res;
  const Eigen::Index n = rows, m = cols;
  Eigen::MatrixXd A(n, m);
  Eigen::VectorXd b(n);
  for (Eigen::Index r = 0; r < n; ++r) {
    b(r) = t[std::size_t(r)];
    for (Eigen::Index c = 0; c < m; ++c) A(r, c) = a[std::size_t(r * m + c)];
  }
  // Columns scaled to unit max-abs, so that rank detection and the tolerances below are not
  // fooled by a 1 (setup) next to 1e9 (bytes); x is unscaled at the end.
  Eigen::VectorXd scale(m);
  for (Eigen::Index c = 0; c < m; ++c) {
    const double s = A.col(c).cwiseAbs().maxCoeff();
    scale(c) = s > 0 ? s : 1.0;
    A.col(c) /= scale(c);
  }
  constexpr double kRankThreshold = 1e-9;  // relative to the largest pivot
  {
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(n, m);
    qr.setThreshold(kRankThreshold);
    qr.compute(A);
    if (qr.rank() < m) return res;  // every column subset is independent from here on
  }

  // Unconstrained least squares on the passive columns (the rest held at 0).
  std::vector<bool> passive(std::size_t(m), false);
  auto solve_passive = [&](Eigen::VectorXd& s) {
    std::vector<Eigen::Index> cols_p;
    for (Eigen::Index c = 0; c < m; ++c)
      if (passive[std::size_t(c)]) cols_p.push_back(c);
    Eigen::MatrixXd Ap(n, Eigen::Index(cols_p.size()));
    for (std::size_t i = 0; i < cols_p.size(); ++i) Ap.col(Eigen::Index(i)) = A.col(cols_p[i]);
    const Eigen::VectorXd sp = Ap.colPivHouseholderQr().solve(b);
    s = Eigen::VectorXd::Zero(m);
    for (std::size_t i = 0; i < cols_p.size(); ++i) s(cols_p[i]) = sp(Eigen::Index(i));
  };

  // Step 1-2: x = 0, every column active (held at 0); w = A^T (b - A x) is the negative
  // gradient of ||A x - b||^2 / 2. The optimum is reached when w_j <= tol on every active j.
  const double eps = std::numeric_limits<double>::epsilon();
  const double tol = 10.0 * eps * double(std::max(n, m)) * A.cwiseAbs().colwise().sum().maxCoeff() *
                     std::max(1.0, b.cwiseAbs().maxCoeff());
  Eigen::VectorXd x = Eigen::VectorXd::Zero(m), s;
  std::vector<bool> refused(std::size_t(m), false);  // anti-cycling: see step 6 below
  const int max_outer = 3 * cols + 10;  // Lawson & Hanson's usual cap; x stays feasible if it is hit
  for (int outer = 0; outer < max_outer; ++outer) {
    const Eigen::VectorXd w = A.transpose() * (b - A * x);
    // Step 3-4: the active column whose constraint is most violated enters the passive set.
    Eigen::Index j = -1;
    for (Eigen::Index c = 0; c < m; ++c)
      if (!passive[std::size_t(c)] && !refused[std::size_t(c)] && w(c) > tol && (j < 0 || w(c) > w(j))) j = c;
    if (j < 0) break;
    passive[std::size_t(j)] = true;
    solve_passive(s);
    // Step 6 guard (Lawson & Hanson's remark on rounding): if the entering column's own
    // coefficient is not positive, w_j > 0 was a rounding artefact; leave it out until the
    // passive set changes, otherwise the loop could cycle.
    if (!(s(j) > 0)) {
      passive[std::size_t(j)] = false;
      refused[std::size_t(j)] = true;
      continue;
    }
    std::fill(refused.begin(), refused.end(), false);
    // Steps 7-11: while the passive solution is infeasible, move from x towards s as far as
    // feasibility allows, and return the columns that reached 0 to the active set.
    for (int inner = 0; inner <= cols; ++inner) {
      double alpha = 1.0;
      Eigen::Index first_zero = -1;  // the passive column that reaches 0 first
      for (Eigen::Index c = 0; c < m; ++c)
        if (passive[std::size_t(c)] && s(c) <= 0) {
          const double a_c = x(c) / (x(c) - s(c));
          if (first_zero < 0 || a_c < alpha) {
            alpha = a_c;
            first_zero = c;
          }
        }
      if (first_zero < 0) break;  // feasible: x = s
      x += alpha * (s - x);
      x(first_zero) = 0;
      for (Eigen::Index c = 0; c < m; ++c)
        if (passive[std::size_t(c)] && x(c) <= 0) {
          passive[std::size_t(c)] = false;
          x(c) = 0;
        }
      solve_passive(s);
    }
    for (Eigen::Index c = 0; c < m; ++c) x(c) = passive[std::size_t(c)] ? std::max(0.0, s(c)) : 0.0;
  }
  res.ok = true;
  res.x.resize(std::size_t(m));
  for (Eigen::Index c = 0; c < m; ++c) res.x[std::size_t(c)] = x(c) / scale(c);
  return res;
}

}  // namespace rayline
