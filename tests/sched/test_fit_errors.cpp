// The error summary of a timing fit (sched/core/fit_errors.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "sched/core/fit_errors.hpp"

namespace rayline {
namespace {

TEST(FitErrors, HandValues) {
  // errors 1, 0.5, 0 and 0.1 on times 1, 2, 0 and 10; relative 1, 0.25, 0.01 (the zero time
  // has none); the weighted one is 1.6 / 13.
  const std::vector<double> pred = {2, 1.5, 0, 10.1}, meas = {1, 2, 0, 10};
  const FitErrors e = fit_errors(pred, meas);
  EXPECT_NEAR(e.rms, std::sqrt((1 + 0.25 + 0 + 0.01) / 4), 1e-15);
  EXPECT_NEAR(e.median_rel, 0.25, 1e-15);
  EXPECT_NEAR(e.max_rel, 1.0, 1e-15);
  EXPECT_NEAR(e.weighted_rel, 1.6 / 13, 1e-15);
  // An even count takes the mean of the two middle ones.
  EXPECT_NEAR(fit_errors(std::vector<double>{2, 1.5}, std::vector<double>{1, 2}).median_rel, (1 + 0.25) / 2, 1e-15);
}

TEST(FitErrors, NothingToCompare) {
  const FitErrors e = fit_errors(std::vector<double>{}, std::vector<double>{});
  EXPECT_TRUE(std::isnan(e.rms) && std::isnan(e.median_rel) && std::isnan(e.weighted_rel) && std::isnan(e.max_rel));
  const FitErrors z = fit_errors(std::vector<double>{1}, std::vector<double>{0});  // no time to be relative to
  EXPECT_EQ(z.rms, 1);
  EXPECT_TRUE(std::isnan(z.median_rel) && std::isnan(z.weighted_rel) && std::isnan(z.max_rel));
  EXPECT_THROW(fit_errors(std::vector<double>{1, 2}, std::vector<double>{1}), std::invalid_argument);
}

}  // namespace
}  // namespace rayline
