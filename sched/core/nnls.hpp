// Non-negative least squares, min ||A x - t||_2 subject to x >= 0, by Lawson and Hanson's
// active-set algorithm NNLS (C. L. Lawson, R. J. Hanson, "Solving Least Squares Problems",
// 1974, Ch. 23, Algorithm 23.10). Used by TimingModel::fit (Sec. 6's least-squares fit of
// Eq. 2), where a negative T_SETUP or T_RATE would be meaningless. Eigen stays in nnls.cpp.
#pragma once

#include <span>
#include <vector>

namespace rayline {

struct NnlsResult {
  // false: A's columns are linearly dependent (relative pivot below 1e-9 after scaling every
  // column to unit max-abs), so the optimum is not unique; x is then empty.
  bool ok = false;
  std::vector<double> x;  // the minimiser, every entry >= 0 (exactly 0 outside the passive set)
};

// A is rows x cols, row-major (a[r * cols + c]); t has rows entries. Requires rows >= cols
// for a unique answer (ok = false otherwise). The result meets the Karush-Kuhn-Tucker
// conditions: the gradient A^T (t - A x) is ~0 where x > 0 and <= ~0 where x = 0.
NnlsResult solve_nnls(std::span<const double> a, int rows, int cols, std::span<const double> t);

}  // namespace rayline
