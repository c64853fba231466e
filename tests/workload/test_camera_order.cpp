// The camera jobs' order (workload/camera_order.hpp): a bijection between the order and the
// sample-major numbering on images of any size (edge tiles narrower), whose pixels come in
// tiles, whose samples of a pixel are consecutive, and whose pixel spans hold every pixel of
// a range; a walk from any ray meets the rays in that order.
#include <gtest/gtest.h>

#include <array>
#include <string>
#include <vector>

#include "workload/camera_order.hpp"

using rayline::CameraOrder;

TEST(CameraOrder, IsABijectionOntoSampleMajorNumbers) {
  for (const auto [w, h, spp] : {std::array<std::uint32_t, 3>{8, 8, 1}, {37, 29, 3}, {1, 5, 2}, {17, 1, 4}, {64, 40, 2}}) {
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h) + "x" + std::to_string(spp));
    const CameraOrder o{w, h, spp};
    const std::uint64_t pixels = std::uint64_t(w) * h;
    std::vector<char> seen(pixels * spp, 0);
    for (std::uint32_t p = 0; p < pixels; ++p) {
      ASSERT_LT(o.position(p), pixels);
      ASSERT_EQ(o.pixel_at(o.position(p)), p);
    }
    for (std::uint64_t j = 0; j < pixels * spp; ++j) {
      const auto [pixel, sample] = o.at(j);
      ASSERT_LT(pixel, pixels);
      ASSERT_LT(sample, spp);
      ASSERT_EQ(sample, j % spp) << "a pixel's samples come one after the other";
      const std::uint64_t i = o.camera_index(j);
      ASSERT_EQ(i, std::uint64_t(sample) * pixels + pixel);
      ASSERT_FALSE(seen[i]) << "camera ray " << i << " twice";
      seen[i] = 1;
    }
  }
}

TEST(CameraOrder, PixelsComeInTilesAndSpansHoldTheirRange) {
  const CameraOrder o{37, 29, 2};
  // The first 64 positions are the top-left 8 x 8 tile.
  for (std::uint64_t pos = 0; pos < 64; ++pos) {
    const std::uint32_t p = o.pixel_at(pos);
    EXPECT_EQ(p % 37, pos % 8);
    EXPECT_EQ(p / 37, pos / 8);
  }
  for (std::uint64_t j = 0; j < 37u * 29u * 2u; j += 7)
    for (const std::uint64_t n : {1u, 13u, 200u}) {
      if (j + n > 37u * 29u * 2u) continue;
      const auto [first, count] = o.pixel_span(j, n);
      for (std::uint64_t k = j; k < j + n; ++k) {
        const std::uint32_t p = o.at(k).first;
        ASSERT_GE(p, first);
        ASSERT_LT(p, first + count) << "ray " << k << " of [" << j << ", +" << n << ")";
      }
      EXPECT_LE(first + count, 37u * 29u);
    }
}

TEST(CameraOrder, WalkFollowsTheOrderFromAnyRay) {
  for (const auto [w, h, spp] : {std::array<std::uint32_t, 3>{8, 8, 1}, {37, 29, 3}, {1, 5, 2}, {17, 1, 4}, {64, 40, 2}}) {
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h) + "x" + std::to_string(spp));
    const CameraOrder o{w, h, spp};
    const std::uint64_t n = std::uint64_t(w) * h * spp;
    for (const std::uint64_t start : {std::uint64_t(0), n / 3, n - 1}) {
      CameraOrder::Walk walk = o.walk(start);
      for (std::uint64_t j = start; j < n; ++j, walk.next()) {
        const auto [pixel, sample] = o.at(j);
        ASSERT_EQ(walk.pixel(), pixel) << "ray " << j << " from " << start;
        ASSERT_EQ(walk.sample, sample) << "ray " << j << " from " << start;
        ASSERT_EQ(walk.x, pixel % w);
        ASSERT_EQ(walk.y, pixel / w);
      }
    }
  }
}
