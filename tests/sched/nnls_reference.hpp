// An independent reference for non-negative least squares, for tests only: the optimum of
// min ||A x - t|| over x >= 0 has x_P = the unconstrained least-squares solution on its
// support P, so it is the best of the subsets' solutions that are >= 0. Enumerating all 2^m
// subsets (m <= ~10) gives it exactly, with a solver that shares nothing with sched/core/nnls.cpp:
// normal equations in long double, Gauss-Jordan with partial pivoting.
#pragma once

#include <cmath>
#include <limits>
#include <vector>

namespace rayline::testing {

struct NnlsReference {
  std::vector<double> x;
  double residual2 = std::numeric_limits<double>::infinity();  // ||A x - t||^2
};

// a: rows x cols, row-major.
inline NnlsReference nnls_by_enumeration(const std::vector<double>& a, int rows, int cols, const std::vector<double>& t) {
  NnlsReference best;
  auto residual2 = [&](const std::vector<double>& x) {
    long double r2 = 0;
    for (int r = 0; r < rows; ++r) {
      long double p = 0;
      for (int c = 0; c < cols; ++c) p += static_cast<long double>(a[std::size_t(r * cols + c)]) * x[std::size_t(c)];
      const long double e = p - t[std::size_t(r)];
      r2 += e * e;
    }
    return static_cast<double>(r2);
  };
  best.x.assign(std::size_t(cols), 0.0);
  best.residual2 = residual2(best.x);  // the empty support
  for (unsigned mask = 1; mask < (1u << cols); ++mask) {
    std::vector<int> p;
    for (int c = 0; c < cols; ++c)
      if (mask & (1u << c)) p.push_back(c);
    const int k = static_cast<int>(p.size());
    // Column scales (max-abs), then the normal equations [S A_P^T A_P S | S A_P^T t].
    std::vector<long double> sc(std::size_t(k), 1);
    for (int i = 0; i < k; ++i) {
      long double m = 0;
      for (int r = 0; r < rows; ++r) m = std::max(m, std::fabs(static_cast<long double>(a[std::size_t(r * cols + p[std::size_t(i)])])));
      sc[std::size_t(i)] = m > 0 ? 1 / m : 1;
    }
    std::vector<std::vector<long double>> g(std::size_t(k), std::vector<long double>(std::size_t(k + 1), 0));
    for (int i = 0; i < k; ++i)
      for (int r = 0; r < rows; ++r) {
        const long double ai = a[std::size_t(r * cols + p[std::size_t(i)])] * sc[std::size_t(i)];
        for (int j = 0; j < k; ++j) g[std::size_t(i)][std::size_t(j)] += ai * a[std::size_t(r * cols + p[std::size_t(j)])] * sc[std::size_t(j)];
        g[std::size_t(i)][std::size_t(k)] += ai * t[std::size_t(r)];
      }
    bool singular = false;
    for (int i = 0; i < k && !singular; ++i) {
      int piv = i;
      for (int r = i + 1; r < k; ++r)
        if (std::fabs(g[std::size_t(r)][std::size_t(i)]) > std::fabs(g[std::size_t(piv)][std::size_t(i)])) piv = r;
      std::swap(g[std::size_t(i)], g[std::size_t(piv)]);
      if (std::fabs(g[std::size_t(i)][std::size_t(i)]) < 1e-15L) singular = true;
      for (int r = 0; r < k && !singular; ++r) {
        if (r == i) continue;
        const long double f = g[std::size_t(r)][std::size_t(i)] / g[std::size_t(i)][std::size_t(i)];
        for (int c = i; c <= k; ++c) g[std::size_t(r)][std::size_t(c)] -= f * g[std::size_t(i)][std::size_t(c)];
      }
    }
    if (singular) continue;
    std::vector<double> x(std::size_t(cols), 0.0);
    bool nonneg = true;
    for (int i = 0; i < k; ++i) {
      const long double v = g[std::size_t(i)][std::size_t(k)] / g[std::size_t(i)][std::size_t(i)] * sc[std::size_t(i)];
      if (v < 0) nonneg = false;
      x[std::size_t(p[std::size_t(i)])] = static_cast<double>(v);
    }
    if (!nonneg) continue;
    const double r2 = residual2(x);
    if (r2 < best.residual2) best = {x, r2};
  }
  return best;
}

}  // namespace rayline::testing
