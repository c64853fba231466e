// The order in which camera jobs make their camera rays (RayBatchOptions::camera_jobs),
// shared by the renderer and its twin: image tiles of kTile x kTile pixels in raster order
// (narrower at the right and bottom edges), the pixels of a tile in raster order, and every
// sample of a pixel one after the other. A camera job is a range of this order, so its rays
// are neighbours (the tutorial-style locality a BVH's cache wants) and each of its pixels
// gets several samples (the film adds them once per job). The image does not depend on it:
// rays are keyed by (pixel, sample), and contributions add in fixed point.
//
// Elsewhere camera ray i is numbered sample-major (pixel i % pixels, sample i / pixels:
// ray logs, the twin's oracle); camera_index() converts.
#pragma once
#include <algorithm>
#include <cstdint>
#include <utility>

namespace rayline {

struct CameraOrder {
  static constexpr std::uint32_t kTile = 8;
  std::uint32_t width = 0, height = 0, spp = 1;

  // The position of a pixel among the image's pixels in tile order.
  std::uint64_t position(std::uint32_t pixel) const {
    const std::uint32_t x = pixel % width, y = pixel / width;
    const std::uint32_t ty = y / kTile * kTile, tx = x / kTile * kTile;
    const std::uint32_t bh = std::min(kTile, height - ty), tw = std::min(kTile, width - tx);
    return std::uint64_t(ty) * width + std::uint64_t(tx) * bh + std::uint64_t(y - ty) * tw + (x - tx);
  }
  // The pixel at a position in tile order (position()'s inverse).
  std::uint32_t pixel_at(std::uint64_t pos) const {
    const auto ty = static_cast<std::uint32_t>(pos / (std::uint64_t(kTile) * width) * kTile);
    const std::uint32_t bh = std::min(kTile, height - ty);
    std::uint64_t r = pos - std::uint64_t(ty) * width;  // within the band of tile rows
    const auto tx = static_cast<std::uint32_t>(r / (std::uint64_t(kTile) * bh) * kTile);
    const std::uint32_t tw = std::min(kTile, width - tx);
    r -= std::uint64_t(tx) * bh;
    return (ty + static_cast<std::uint32_t>(r / tw)) * width + tx + static_cast<std::uint32_t>(r % tw);
  }
  // Camera ray j of the order: its pixel and sample.
  std::pair<std::uint32_t, std::uint32_t> at(std::uint64_t j) const {
    return {pixel_at(j / spp), static_cast<std::uint32_t>(j % spp)};
  }
  // Walks the order from camera ray j on, one ray per next(), without a division per ray
  // (a camera job's loop: at() costs eight 64-bit divisions).
  struct Walk {
    std::uint32_t x = 0, y = 0, sample = 0;  // the current ray's pixel column, row and sample
    std::uint32_t tx = 0, ty = 0, tw = 0, th = 0;  // its tile: corner and size
    std::uint32_t width = 0, height = 0, spp = 1;
    std::uint32_t pixel() const { return y * width + x; }
    void next() {
      if (++sample < spp) return;
      sample = 0;
      if (++x < tx + tw) return;
      x = tx;
      if (++y < ty + th) return;
      tx += kTile;  // the next tile: right, else the first of the next band
      if (tx >= width) tx = 0, ty += kTile;
      tw = std::min(kTile, width - tx);
      th = ty < height ? std::min(kTile, height - ty) : 0;
      x = tx, y = ty;
    }
  };
  Walk walk(std::uint64_t j) const {
    const auto [pixel, sample] = at(j);
    Walk w;
    w.width = width, w.height = height, w.spp = spp;
    w.x = pixel % width, w.y = pixel / width, w.sample = sample;
    w.tx = w.x / kTile * kTile, w.ty = w.y / kTile * kTile;
    w.tw = std::min(kTile, width - w.tx), w.th = std::min(kTile, height - w.ty);
    return w;
  }
  // Its sample-major number.
  std::uint64_t camera_index(std::uint64_t j) const {
    const auto [pixel, sample] = at(j);
    return std::uint64_t(sample) * width * height + pixel;
  }
  // The raster pixels [first, first + count) that hold every pixel of rays [j, j + n): the
  // rows of the bands of tiles they fall in.
  std::pair<std::uint32_t, std::uint32_t> pixel_span(std::uint64_t j, std::uint64_t n) const {
    const std::uint64_t band = std::uint64_t(kTile) * width;
    const std::uint64_t first_row = (j / spp) / band * kTile;
    const std::uint64_t end_row = std::min<std::uint64_t>(((j + n - 1) / spp) / band * kTile + kTile, height);
    return {static_cast<std::uint32_t>(first_row * width), static_cast<std::uint32_t>((end_row - first_row) * width)};
  }
};

}  // namespace rayline
