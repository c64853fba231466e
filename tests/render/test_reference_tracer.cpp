// The in-core reference path tracer (render/reference), the oracle of the batching
// renderer, checked against closed-form answers:
//  * furnace (scenes/furnace.json: closed sphere, albedo a = 0.5, emission E = 0.5, camera
//    inside): every pixel converges to L = E·Σ_{i<D} a^i. Without roulette (D <= 3) every
//    path returns exactly L. With roulette (D = 8) the per-sample distribution is known
//    exactly (the throughput is grey and deterministic given survival), so the test uses
//    its exact mean μ and standard deviation σ: image mean within 4·σ/sqrt(N·spp) of μ,
//    every pixel inside the exact band its spp-sample mean leaves with probability
//    <= 1e-9, and the tracer's own variance output within 10 % of σ² on average;
//  * next-event estimation: a diffuse floor under a square area light (plus a second light
//    facing away, which halves the sampling pdf and must add nothing), a tiny field of view
//    at the point below the light's centre: L = ρ·Le·F + ρ·Env with F the closed-form
//    point-to-parallel-rectangle form factor; image mean within 4 standard errors (from
//    the tracer's variances) and within 1 % of L;
//  * camera convention: emissive quads at known places appear in exactly the pixels the
//    convention puts them in (y = 0 the top row, +x to the right, fov_y, aspect), both
//    faces emitting;
//  * Cornell box: finite, non-negative, mean luminance within a factor 2 of 0.070, red
//    wall on the left and green on the right, the light itself invisible; bit-identical for
//    a seed whatever the threads.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "render/reference/reference.hpp"
#include "render/scene/ply_writer.hpp"
#include "render/scene/scene.hpp"
#include "common/error.hpp"

namespace fs = std::filesystem;
using rayline::reference::ReferenceImage;
using rayline::reference::ReferenceOptions;
using rayline::reference::render_reference;
using namespace rayline::scene;

namespace {

// Scratch folder for generated meshes, removed at the end of the test.
struct TempDir {
  fs::path dir;
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir = fs::temp_directory_path() /
          ("rayline-reference-" + std::string(info->name()) + "-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

// Writes the parallelogram corner + s·u + t·v as two triangles (winding along u then v).
std::string write_quad(const fs::path& file, Float3 corner, Float3 u, Float3 v) {
  PlyWriter w(file.string());
  const std::vector<Float3> p = {corner, corner + u, corner + u + v, corner + v};
  const std::vector<Tri> t = {{0, 1, 2}, {0, 2, 3}};
  w.add(MeshPiece{p, t, 0});
  w.finish();
  return file.string();
}

MeshInstance mesh(const std::string& file, std::uint32_t material) {
  MeshInstance m;
  m.name = fs::path(file).stem().string();
  m.file = file;
  m.material = material;
  return m;
}

struct Stats {
  double mean = 0, max_abs_dev = 0, mean_variance = 0;
};

// Channel statistics over the whole image: mean of pixel means, mean of the tracer's
// per-pixel sample variances, largest |pixel − expect|.
Stats channel_stats(const ReferenceImage& im, int c, double expect) {
  Stats s;
  const std::size_t n = std::size_t(im.width) * std::size_t(im.height);
  for (std::size_t p = 0; p < n; ++p) {
    s.mean += im.rgb[p * 3 + std::size_t(c)];
    s.mean_variance += im.variance[p * 3 + std::size_t(c)];
    s.max_abs_dev = std::max(s.max_abs_dev, std::fabs(double(im.rgb[p * 3 + std::size_t(c)]) - expect));
  }
  s.mean /= double(n);
  s.mean_variance /= double(n);
  return s;
}

// Exact distribution of one furnace sample (grey albedo a, emission E, depth D, the
// tracer's roulette): hit d is reached with probability P_d and the path has gathered S_d
// by then; it stops after hit d with probability P_d − P_{d+1}. Returns (S_d, probability)
// for every d with a non-zero probability.
std::vector<std::pair<double, double>> furnace_distribution(double a, double E, int D) {
  std::vector<std::pair<double, double>> out;
  double P = 1, T = 1, S = 0;
  for (int d = 1; d <= D; ++d) {
    S += E * T;  // emission at hit d
    double next_P = 0;
    if (d < D) {
      T *= a;
      double q = 1;
      if (d >= 3) q = std::min(0.95, double(float(T))), T /= q;  // the tracer's float q
      next_P = P * q;
    }
    if (P - next_P > 0) out.push_back({S, P - next_P});
    P = next_P;
  }
  return out;
}

std::pair<double, double> moments(const std::vector<std::pair<double, double>>& dist) {
  double m1 = 0, m2 = 0;
  for (const auto& [v, p] : dist) m1 += p * v, m2 += p * v * v;
  return {m1, m2 - m1 * m1};
}

// The band [lo, hi] that the mean of `spp` i.i.d. samples of `dist` leaves with probability
// at most alpha (alpha/2 each side), computed exactly: the values lie on a lattice
// v_0 + k·step, so the sum of the k's has the spp-fold convolution of their pmf.
std::pair<double, double> mean_band(const std::vector<std::pair<double, double>>& dist, int spp, double alpha) {
  const double v0 = dist.front().first, step = dist.size() > 1 ? dist[1].first - v0 : 1.0;
  std::vector<double> pmf1;
  for (const auto& [v, p] : dist) {
    const double k = (v - v0) / step;
    EXPECT_NEAR(k, std::round(k), 1e-9) << "values on a lattice";
    pmf1.resize(std::size_t(std::llround(k)) + 1, 0.0);
    pmf1[std::size_t(std::llround(k))] += p;
  }
  std::vector<double> pmf = {1.0};
  for (int i = 0; i < spp; ++i) {
    std::vector<double> next(pmf.size() + pmf1.size() - 1, 0.0);
    for (std::size_t x = 0; x < pmf.size(); ++x)
      for (std::size_t y = 0; y < pmf1.size(); ++y) next[x + y] += pmf[x] * pmf1[y];
    pmf = std::move(next);
  }
  std::size_t lo = 0, hi = pmf.size() - 1;
  for (double tail = pmf[lo]; tail <= alpha / 2 && lo + 1 < pmf.size();) tail += pmf[++lo];
  for (double tail = pmf[hi]; tail <= alpha / 2 && hi > 0;) tail += pmf[--hi];
  return {v0 + step * double(lo) / spp, v0 + step * double(hi) / spp};
}

Scene furnace_scene() { return load_scene(std::string(RAYLINE_SCENES_DIR) + "/furnace.json"); }

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

TEST(reference, FurnaceWithoutRouletteIsExact) {
  const Scene sc = furnace_scene();
  for (int depth : {1, 2, 3}) {
    ReferenceOptions o;
    o.width = o.height = 32;
    o.spp = 4;
    o.max_depth = depth;
    o.threads = 2;
    const ReferenceImage im = render_reference(sc, o);
    double expect = 0;
    for (int i = 0; i < depth; ++i) expect += 0.5 * std::pow(0.5, i);
    for (int c = 0; c < 3; ++c) {
      const Stats s = channel_stats(im, c, expect);
      // Every path sees exactly E·a^(d−1) at hit d: only float rounding remains.
      EXPECT_LT(s.max_abs_dev, 1e-5) << "depth " << depth << " channel " << c;
      EXPECT_LT(s.mean_variance, 1e-10) << "depth " << depth;
    }
  }
}

TEST(reference, FurnaceWithRouletteWithinStandardErrors) {
  const Scene sc = furnace_scene();
  ReferenceOptions o;
  o.width = o.height = 64;
  o.spp = 64;
  o.max_depth = 8;
  o.threads = 2;
  o.seed = 11;
  const ReferenceImage im = render_reference(sc, o);
  const auto dist = furnace_distribution(0.5, 0.5, o.max_depth);
  const auto [mu, var] = moments(dist);
  // Per pixel: the exact band a 64-sample mean leaves with probability <= 1e-9 (so <= 4.1e-6
  // for any of the 4 096 pixels); the per-sample law is skewed (roulette survival 1/8, then
  // up to +2.5), so a normal-theory k·σ band would be either loose or wrong.
  const auto [band_lo, band_hi] = mean_band(dist, o.spp, 1e-9);
  double expect = 0;
  for (int i = 0; i < o.max_depth; ++i) expect += 0.5 * std::pow(0.5, i);
  ASSERT_NEAR(mu, expect, 1e-9) << "roulette keeps the estimator unbiased";
  const double sigma = std::sqrt(var);
  const double n = double(im.width) * double(im.height);
  for (int c = 0; c < 3; ++c) {
    const Stats s = channel_stats(im, c, mu);
    EXPECT_NEAR(s.mean, mu, 4 * sigma / std::sqrt(n * o.spp)) << "channel " << c;
    for (std::size_t p = 0; p < std::size_t(n); ++p) {
      const float v = im.rgb[p * 3 + std::size_t(c)];
      ASSERT_TRUE(v >= band_lo - 1e-5 && v <= band_hi + 1e-5) << "pixel " << p << " = " << v;
    }
    EXPECT_NEAR(s.mean_variance, var, 0.1 * var) << "the tracer's sample variances estimate σ²";
    if (c == 0)
      std::printf("furnace D=%d: mean %.6f (exact %.6f, se %.6f), max |pixel - exact| %.4f (band %.4f..%.4f), "
                  "mean s^2 %.5f (exact %.5f)\n",
                  o.max_depth, s.mean, mu, sigma / std::sqrt(n * o.spp), s.max_abs_dev, band_lo, band_hi,
                  s.mean_variance, var);
  }
}

TEST(reference, NextEventEstimationMatchesFormFactor) {
  TempDir tmp;
  Scene sc;
  sc.source = "<nee-test>";
  const float rho = 0.5f, Le = 2.0f, env = 0.25f;
  sc.materials = {{"floor", {rho, rho, rho}, {0, 0, 0}}};
  // A 200 m floor at y = 0, facing up; its continuation rays all escape to the environment.
  sc.meshes = {mesh(write_quad(tmp.dir / "floor.ply", {-100, 0, -100}, {0, 0, 200}, {200, 0, 0}), 0)};
  // Light 1 m square at height h = 1, centred above the origin, emitting down
  // (cross(edge_u, edge_v) = −y). Light 2 emits up: it never reaches the floor, but halves
  // the probability of picking light 1 (pdf_area = 1 / (2·area)).
  sc.area_lights = {{"down", {-0.5f, 1, -0.5f}, {1, 0, 0}, {0, 0, 1}, {Le, Le, Le}},
                    {"up", {-0.5f, 1.5f, -0.5f}, {0, 0, 1}, {1, 0, 0}, {Le, Le, Le}}};
  sc.environment.radiance = {env, env, env};
  Camera cam;
  cam.position = {0, 0.5f, 0};  // between floor and light: lights never occlude
  cam.look_at = {0, 0, 0};
  cam.up = {0, 0, -1};
  cam.fov_y_deg = 0.02f;  // sees only the point below the light's centre
  cam.width = cam.height = 16;
  sc.cameras = {cam};

  // Form factor from a point to a parallel a×b rectangle whose corner is straight above it
  // at height h: F = 1/(2π)·[X/√(1+X²)·atan(Y/√(1+X²)) + Y/√(1+Y²)·atan(X/√(1+Y²))],
  // X = a/h, Y = b/h; the centre point sums four 0.5×0.5 quarters.
  const double X = 0.5, Y = 0.5;
  const double Fq = (X / std::sqrt(1 + X * X) * std::atan(Y / std::sqrt(1 + X * X)) +
                     Y / std::sqrt(1 + Y * Y) * std::atan(X / std::sqrt(1 + Y * Y))) /
                    (2 * std::numbers::pi);
  const double expect = rho * Le * 4 * Fq + rho * env;  // Lo = ρ/π·E, E = π·Le·F; + ρ·Env

  ReferenceOptions o;
  o.spp = 64;
  o.max_depth = 2;
  o.threads = 2;
  const ReferenceImage im = render_reference(sc, o);
  const double n = double(im.width) * double(im.height);
  for (int c = 0; c < 3; ++c) {
    const Stats s = channel_stats(im, c, expect);
    const double se = std::sqrt(s.mean_variance / (n * o.spp));
    EXPECT_NEAR(s.mean, expect, 4 * se) << "channel " << c << " se " << se;
    EXPECT_NEAR(s.mean, expect, 0.01 * expect) << "channel " << c;
    if (c == 0) std::printf("NEE: mean %.6f, exact %.6f, se %.6f\n", s.mean, expect, se);
  }
  // Depth 1: no continuation, so no environment behind the floor.
  o.max_depth = 1;
  const ReferenceImage one = render_reference(sc, o);
  const double direct = rho * Le * 4 * Fq;
  const Stats s = channel_stats(one, 0, direct);
  EXPECT_NEAR(s.mean, direct, 4 * std::sqrt(s.mean_variance / (n * o.spp)));
}

TEST(reference, CameraConventionAndTwoSidedEmission) {
  TempDir tmp;
  Scene sc;
  sc.source = "<camera-test>";
  sc.materials = {{"red", {0, 0, 0}, {1, 0, 0}}, {"green", {0, 0, 0}, {0, 1, 0}}};
  // 90° vertical fov, aspect 2: the plane z = −1 shows x in [−2, 2], y in [−1, 1].
  // Red: x in [0, 1], y in [0.5, 1] → columns 16..23, rows 0..3 (top rows, right of centre);
  // wound to face the camera. Green: x in [−2, −1], y in [−1, −0.5] → columns 0..7, rows
  // 12..15; wound to face away (emission is two-sided).
  sc.meshes = {mesh(write_quad(tmp.dir / "red.ply", {0, 0.5f, -1}, {1, 0, 0}, {0, 0.5f, 0}), 0),
               mesh(write_quad(tmp.dir / "green.ply", {-2, -1, -1}, {0, 0.5f, 0}, {1, 0, 0}), 1)};
  sc.environment.radiance = {0, 0, 0.5f};
  Camera cam;
  cam.position = {0, 0, 0};
  cam.look_at = {0, 0, -1};
  cam.up = {0, 1, 0};
  cam.fov_y_deg = 90;
  cam.width = 32, cam.height = 16;
  sc.cameras = {cam};
  ReferenceOptions o;
  o.spp = 4;
  o.max_depth = 3;
  o.threads = 2;
  const ReferenceImage im = render_reference(sc, o);
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const bool red = x >= 16 && x < 24 && y < 4, green = x < 8 && y >= 12;
      EXPECT_EQ(im.rgb[im.index(x, y, 0)], red ? 1.0f : 0.0f) << x << "," << y;
      EXPECT_EQ(im.rgb[im.index(x, y, 1)], green ? 1.0f : 0.0f) << x << "," << y;
      EXPECT_EQ(im.rgb[im.index(x, y, 2)], red || green ? 0.0f : 0.5f) << x << "," << y << " environment";
    }
}

TEST(reference, CornellBoxSaneAndDeterministic) {
  const Scene sc = load_scene(std::string(RAYLINE_SCENES_DIR) + "/cornell.json");
  ReferenceOptions o;
  o.width = o.height = 64;
  o.spp = 16;
  o.max_depth = 5;
  o.seed = 7;
  o.threads = 2;
  const auto t0 = std::chrono::steady_clock::now();
  const ReferenceImage a = render_reference(sc, o);
  const double secs = seconds_since(t0);
  double sum[3] = {0, 0, 0}, left[3] = {0, 0, 0}, right[3] = {0, 0, 0};
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x)
      for (int c = 0; c < 3; ++c) {
        const float v = a.rgb[a.index(x, y, c)];
        ASSERT_TRUE(std::isfinite(v) && v >= 0) << x << "," << y << " = " << v;
        ASSERT_TRUE(std::isfinite(a.variance[a.index(x, y, c)]) && a.variance[a.index(x, y, c)] >= 0);
        sum[c] += v;
        // Middle rows of the outer columns: the side walls.
        if (y > a.height / 4 && y < 3 * a.height / 4) {
          if (x < a.width / 10) left[c] += v;
          if (x >= a.width - a.width / 10) right[c] += v;
        }
      }
  const double n = double(a.width) * double(a.height);
  const double lum = (0.2126 * sum[0] + 0.7152 * sum[1] + 0.0722 * sum[2]) / n;
  std::printf("cornell 64x64x%d: mean luminance %.4f, left RGB %.3f %.3f %.3f, right RGB %.3f %.3f %.3f, %.3f s "
              "(build %.3f s, %llu triangles)\n",
              o.spp, lum, left[0], left[1], left[2], right[0], right[1], right[2], secs, a.build_seconds,
              (unsigned long long)a.triangles);
  // Plausible: within a factor 2 of 0.070, the mean luminance of this view at depth 5 (the
  // batching renderer gives the same within 1.5 standard errors at 64 and 1 024 spp).
  EXPECT_GT(lum, 0.035);
  EXPECT_LT(lum, 0.14);
  EXPECT_GT(left[0], 2 * left[1]) << "red wall on the left (x = 0, camera looks down −z)";
  EXPECT_GT(right[1], 1.5 * right[0]) << "green wall on the right";
  // The light (y = 0.998, x and z in [0.4, 0.6], radiance 17/12/4) is invisible: the top
  // rows of the centre columns, where it would appear, show the lit ceiling instead.
  for (int y = 0; y < 4; ++y)
    for (int x = a.width / 2 - 6; x < a.width / 2 + 6; ++x)
      EXPECT_LT(a.rgb[a.index(x, y, 0)], 5.0f) << x << "," << y << ": the area light must not be visible";

  // Deterministic for a seed, whatever the thread count; another seed differs.
  o.threads = 1;
  const ReferenceImage b = render_reference(sc, o);
  EXPECT_EQ(a.rgb, b.rgb);
  EXPECT_EQ(a.variance, b.variance);
  o.seed = 8;
  const ReferenceImage c = render_reference(sc, o);
  EXPECT_NE(a.rgb, c.rgb);
  RecordProperty("first_render_seconds", std::to_string(secs));
}

TEST(reference, RejectsBadOptions) {
  const Scene sc = furnace_scene();
  ReferenceOptions o;
  o.width = o.height = 4;
  o.spp = 1;
  o.max_depth = 0;
  EXPECT_THROW(render_reference(sc, o), rayline::InputError);
  o.max_depth = 2;
  o.camera = 3;
  EXPECT_THROW(render_reference(sc, o), rayline::InputError);
}
