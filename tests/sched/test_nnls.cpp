// Lawson-Hanson NNLS (sched/core/nnls.hpp) against an exhaustive reference and its optimality
// (Karush-Kuhn-Tucker) conditions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "nnls_reference.hpp"
#include "sched/core/nnls.hpp"

namespace rayline {
namespace {

double residual2(const std::vector<double>& a, int rows, int cols, const std::vector<double>& t,
                 const std::vector<double>& x) {
  double r2 = 0;
  for (int r = 0; r < rows; ++r) {
    double p = -t[std::size_t(r)];
    for (int c = 0; c < cols; ++c) p += a[std::size_t(r * cols + c)] * x[std::size_t(c)];
    r2 += p * p;
  }
  return r2;
}

TEST(Nnls, IdentityClipsTheNegativeEntries) {
  const std::vector<double> a = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const NnlsResult r = solve_nnls(a, 3, 3, std::vector<double>{1, -2, 3});
  ASSERT_TRUE(r.ok);
  EXPECT_DOUBLE_EQ(r.x[0], 1);
  EXPECT_EQ(r.x[1], 0);
  EXPECT_DOUBLE_EQ(r.x[2], 3);
}

// A dropped column must be able to come back. The unconstrained optimum here is
// (15, -3, -6): (15, -9, -12) with the columns scaled to unit max-abs. Dropping the most
// negative scaled coefficient and refitting, (a tempting shortcut for NNLS) drops
// column 2, then column 1, and ends at (1.5, 0, 0) with residual^2 11. The optimum brings
// column 2 back and drops column 0: (0, 0, 12/13), residual^2 116/13.
TEST(Nnls, ADroppedColumnComesBack) {
  const std::vector<double> a = {1, 0, 2,  //
                                 1, 1, 2,  //
                                 1, 0, 2,  //
                                 1, 3, 1};
  const std::vector<double> t = {2, 0, 4, 0};
  const NnlsResult r = solve_nnls(a, 4, 3, t);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.x[0], 0);
  EXPECT_EQ(r.x[1], 0);
  EXPECT_NEAR(r.x[2], 12.0 / 13.0, 1e-12);
  EXPECT_NEAR(residual2(a, 4, 3, t, r.x), 116.0 / 13.0, 1e-12);
  const testing::NnlsReference ref = testing::nnls_by_enumeration(a, 4, 3, t);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(r.x[std::size_t(c)], ref.x[std::size_t(c)], 1e-12) << "column " << c;
}

TEST(Nnls, DependentColumnsOrTooFewRowsAreNotSolved) {
  EXPECT_FALSE(solve_nnls(std::vector<double>{1, 2, 2, 4, 3, 6}, 3, 2, std::vector<double>{1, 2, 3}).ok);
  EXPECT_FALSE(solve_nnls(std::vector<double>{1, 2, 3, 4, 5, 6}, 2, 3, std::vector<double>{1, 2}).ok);
  EXPECT_FALSE(solve_nnls(std::vector<double>{0, 1, 0, 2}, 2, 2, std::vector<double>{1, 2}).ok);  // a zero column
}

// Property: on random problems (general signs, 1-7 columns, scales from 1 to 1e9 as in
// Eq. 2's setup-vs-bytes columns) the result is feasible, meets the KKT conditions and
// reaches the exhaustive optimum's residual.
TEST(Nnls, ReachesTheExhaustiveOptimumOnRandomProblems) {
  std::mt19937 rng(20261204);
  std::uniform_real_distribution<double> u(-1, 1);
  int instances = 0, active_at_optimum = 0;
  double worst_rel = 0;
  for (int it = 0; it < 2000; ++it) {
    const int cols = 1 + int(rng() % 7), rows = cols + int(rng() % 10);
    std::vector<double> sc(static_cast<std::size_t>(cols));
    for (double& s : sc) s = std::pow(10.0, 9.0 * (u(rng) + 1) / 2);
    std::vector<double> a(static_cast<std::size_t>(rows * cols)), t(static_cast<std::size_t>(rows));
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c < cols; ++c) a[std::size_t(r * cols + c)] = (it % 2 ? std::fabs(u(rng)) : u(rng)) * sc[std::size_t(c)];
      t[std::size_t(r)] = it % 2 ? std::fabs(u(rng)) * 10 : u(rng) * 10;
    }
    const NnlsResult r = solve_nnls(a, rows, cols, t);
    if (!r.ok) continue;
    ++instances;
    for (double v : r.x) ASSERT_GE(v, 0.0);
    const testing::NnlsReference ref = testing::nnls_by_enumeration(a, rows, cols, t);
    const double r2 = residual2(a, rows, cols, t, r.x);
    double t2 = 0;
    for (double v : t) t2 += v * v;
    const double excess = (r2 - ref.residual2) / t2;  // relative to ||t||^2
    worst_rel = std::max(worst_rel, excess);
    ASSERT_LE(r2 - ref.residual2, 1e-9 * ref.residual2 + 1e-12 * t2) << "instance " << it << ": " << rows << "x" << cols;
    // KKT: w = A^T (t - A x); w_c ~ 0 where x_c > 0, w_c <= ~0 where x_c = 0.
    for (int c = 0; c < cols; ++c) {
      double w = 0, norm = 0;
      for (int k = 0; k < rows; ++k) {
        double res = t[std::size_t(k)];
        for (int j = 0; j < cols; ++j) res -= a[std::size_t(k * cols + j)] * r.x[std::size_t(j)];
        w += a[std::size_t(k * cols + c)] * res;
        norm += std::fabs(a[std::size_t(k * cols + c)]) * (std::fabs(t[std::size_t(k)]) + 1);
      }
      if (r.x[std::size_t(c)] > 0)
        ASSERT_LE(std::fabs(w), 1e-8 * norm) << "instance " << it << " column " << c;
      else {
        ASSERT_LE(w, 1e-8 * norm) << "instance " << it << " column " << c;
        ++active_at_optimum;
      }
    }
  }
  EXPECT_GT(instances, 1500);
  EXPECT_GT(active_at_optimum, 1000);  // the constraints mattered in many instances
  std::printf("NNLS vs exhaustive optimum: %d instances, %d columns held at 0, worst residual^2 excess over it %.3g of ||t||^2\n",
              instances, active_at_optimum, worst_rel);
}

}  // namespace
}  // namespace rayline
