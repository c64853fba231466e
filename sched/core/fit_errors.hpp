// How well a fitted timing equation (Eq. 1 or Eq. 2, Sec. 3.2) predicts its own samples.
// The worst relative error belongs to the shortest samples (a job of a few rays measured in
// microseconds against a predicted T_SETUP, a load served from the page cache), so it says
// little on its own; the median and the time-weighted error say how well the model predicts
// the time that the schedule is made of.
#pragma once

#include <limits>
#include <span>

namespace rayline {

struct FitErrors {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  double rms = kNaN;           // seconds
  double median_rel = kNaN;    // median |pred - meas| / meas over samples with meas > 0
  double weighted_rel = kNaN;  // sum |pred - meas| / sum meas
  double max_rel = kNaN;       // max |pred - meas| / meas over samples with meas > 0
};

// predicted and measured have the same length (seconds). Empty input: all NaN.
FitErrors fit_errors(std::span<const double> predicted, std::span<const double> measured);

}  // namespace rayline
