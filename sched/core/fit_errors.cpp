// Error summary of a timing fit; see fit_errors.hpp.
#include "sched/core/fit_errors.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace rayline {

FitErrors fit_errors(std::span<const double> predicted, std::span<const double> measured) {
  if (predicted.size() != measured.size()) throw std::invalid_argument("fit_errors: sizes differ");
  FitErrors e;
  if (measured.empty()) return e;
  double sq = 0, abs_sum = 0, time_sum = 0;
  std::vector<double> rel;
  rel.reserve(measured.size());
  for (std::size_t i = 0; i < measured.size(); ++i) {
    const double err = std::abs(predicted[i] - measured[i]);
    sq += err * err;
    abs_sum += err;
    time_sum += measured[i];
    if (measured[i] > 0) rel.push_back(err / measured[i]);
  }
  e.rms = std::sqrt(sq / double(measured.size()));
  if (time_sum > 0) e.weighted_rel = abs_sum / time_sum;
  if (!rel.empty()) {
    std::sort(rel.begin(), rel.end());
    const std::size_t h = rel.size() / 2;
    e.median_rel = rel.size() % 2 ? rel[h] : (rel[h - 1] + rel[h]) / 2;
    e.max_rel = rel.back();
  }
  return e;
}

}  // namespace rayline
