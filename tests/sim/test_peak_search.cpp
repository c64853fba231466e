// The client sweep that finds the peak by itself (sim/peak_search.hpp): doubling client
// counts, stopping after two points in a row that do not beat the best by more than 2 %.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "sim/peak_search.hpp"

using namespace rayline::sim;

namespace {
// Runs the sweep on a synthetic throughput curve; returns the points measured.
std::vector<PeakPoint> sweep(const std::function<double(int)>& curve, PeakSearch opt = {}) {
  std::vector<PeakPoint> pts;
  for (int n = next_peak_point(pts, opt); n != 0; n = next_peak_point(pts, opt)) pts.push_back({n, curve(n), true});
  return pts;
}
std::vector<int> clients(const std::vector<PeakPoint>& pts) {
  std::vector<int> c;
  for (const auto& p : pts) c.push_back(p.clients);
  return c;
}
}  // namespace

TEST(PeakSearch, RisesThenFallsStopsTwoPointsAfterThePeak) {
  // Peak at 16 clients: 1 2 4 8 16 improve, 32 and 64 fall.
  const auto pts = sweep([](int n) { return n <= 16 ? 10.0 * n : 160.0 - (n - 16); });
  EXPECT_EQ(clients(pts), (std::vector<int>{1, 2, 4, 8, 16, 32, 64}));
  EXPECT_EQ(peak_of(pts).clients, 16);
  EXPECT_DOUBLE_EQ(peak_of(pts).rate, 160.0);
}

TEST(PeakSearch, APlateauWithinTheGainEndsTheSweep) {
  // Saturates at 8 clients: 16 and 32 gain 1 % each, under the 2 % threshold.
  const auto pts = sweep([](int n) { return n <= 8 ? double(n) : 8.0 * std::pow(1.01, std::log2(n / 8.0)); });
  EXPECT_EQ(clients(pts), (std::vector<int>{1, 2, 4, 8, 16, 32}));
  EXPECT_EQ(peak_of(pts).clients, 32) << "the best point measured, even if barely better";
}

TEST(PeakSearch, ADipThenARiseKeepsGoing) {
  // One point below the best is not the end: 4 dips, 8 beats the best again.
  const auto pts = sweep([](int n) { return n == 4 ? 1.0 : n <= 8 ? double(n) : 8.0; });
  EXPECT_EQ(clients(pts), (std::vector<int>{1, 2, 4, 8, 16, 32}));
  EXPECT_EQ(peak_of(pts).clients, 8);
}

TEST(PeakSearch, StopsAtTheClientLimit) {
  PeakSearch opt;
  opt.max_clients = 64;
  const auto pts = sweep([](int n) { return double(n); }, opt);
  EXPECT_EQ(clients(pts).back(), 64);
  EXPECT_EQ(peak_of(pts).clients, 64);
}

TEST(PeakSearch, StillRisingAtTheLimitMeasuresTheLimitLast) {
  // The default limit is the workload's 1023 clients: 512 doubles to 1023, not 1024.
  const auto pts = sweep([](int n) { return double(n); });
  EXPECT_EQ(clients(pts), (std::vector<int>{1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1023}));
  EXPECT_EQ(peak_of(pts).clients, 1023);
}

TEST(PeakSearch, NoPointsMeansStartAtOneClient) {
  EXPECT_EQ(next_peak_point({}), 1);
  EXPECT_EQ(peak_of({}).clients, 0);
}

// An offered load the cluster cannot absorb: the rays alive grow, and the rate read in a
// short window is not one that holds. Two such points in a row end the sweep, and the
// peak is the best steady one, even when the overloaded points read higher.
TEST(PeakSearch, UnsteadyPointsAreMissesAndNeverThePeak) {
  std::vector<PeakPoint> pts;
  for (int n = next_peak_point(pts); n != 0; n = next_peak_point(pts)) pts.push_back({n, 10.0 * n, n < 16});
  EXPECT_EQ(clients(pts), (std::vector<int>{1, 2, 4, 8, 16, 32}));
  EXPECT_EQ(peak_of(pts).clients, 8);
  EXPECT_TRUE(peak_of(pts).steady);
}

// One unsteady point (in-flight budgets still filling at a low load) does not end the
// sweep: the next steady point that gains continues it.
TEST(PeakSearch, OneUnsteadyPointThenARiseKeepsGoing) {
  std::vector<PeakPoint> pts;
  for (int n = next_peak_point(pts); n != 0; n = next_peak_point(pts))
    pts.push_back({n, n <= 16 ? 10.0 * n : 160.0, n != 2});
  EXPECT_EQ(clients(pts), (std::vector<int>{1, 2, 4, 8, 16, 32, 64}));
  EXPECT_EQ(peak_of(pts).clients, 16);
}

TEST(PeakSearch, NoSteadyPointGivesTheBestUnsteadyOne) {
  const std::vector<PeakPoint> pts{{1, 5.0, false}, {2, 6.0, false}};
  EXPECT_EQ(next_peak_point({pts[0]}), 2);
  EXPECT_EQ(next_peak_point(pts), 0);
  EXPECT_EQ(peak_of(pts).clients, 2);
  EXPECT_FALSE(peak_of(pts).steady);
}
