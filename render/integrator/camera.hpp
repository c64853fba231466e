// Pinhole camera: pixel (x, y), y = 0 the top row, sample position (x+u, y+v)
// with (u, v) keyed by (pixel, sample) so a pixel's samples never depend on scheduling.
#pragma once
#include <cstdint>

#include "render/integrator/sampler.hpp"
#include "render/scene/scene.hpp"

namespace rayline::trace {

class PinholeCamera {
 public:
  PinholeCamera(const scene::Camera& c, int width, int height);
  int width() const { return width_; }
  int height() const { return height_; }
  scene::Float3 position() const { return pos_; }
  // Unit direction of sample `sample` through pixel `pixel` (= y·width + x).
  scene::Float3 direction(std::uint32_t pixel, std::uint32_t sample, std::uint64_t seed) const;
  // The same direction, for a caller that walks pixels by column x and row y and keys the
  // seed once (camera jobs: no division, one hash fewer per ray).
  scene::Float3 direction(std::uint32_t x, std::uint32_t y, std::uint32_t sample, SeedKey seed) const;

 private:
  int width_, height_;
  scene::Float3 pos_, forward_, right_, up_;
  float tan_half_, aspect_;
};

}  // namespace rayline::trace
