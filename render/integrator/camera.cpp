#include "render/integrator/camera.hpp"

#include <cmath>

namespace rayline::trace {

using scene::cross;
using scene::normalize;

PinholeCamera::PinholeCamera(const scene::Camera& c, int width, int height)
    : width_(width), height_(height), pos_(c.position) {
  forward_ = normalize(c.look_at - c.position);
  right_ = normalize(cross(forward_, c.up));
  up_ = cross(right_, forward_);
  tan_half_ = static_cast<float>(std::tan(double(c.fov_y_deg) * 3.14159265358979323846 / 360.0));
  aspect_ = float(width) / float(height);
}

scene::Float3 PinholeCamera::direction(std::uint32_t pixel, std::uint32_t sample, std::uint64_t seed) const {
  const auto w = std::uint32_t(width_);
  return direction(pixel % w, pixel / w, sample, SeedKey(seed));
}

scene::Float3 PinholeCamera::direction(std::uint32_t x, std::uint32_t y, std::uint32_t sample, SeedKey seed) const {
  const KeyedRng rng(seed, y * std::uint32_t(width_) + x, sample, 0, Purpose::PixelJitter);
  const float fx = float(x) + rng.uniform(0);
  const float fy = float(y) + rng.uniform(1);
  const float sx = (2 * fx / float(width_) - 1) * tan_half_ * aspect_;
  const float sy = (1 - 2 * fy / float(height_)) * tan_half_;
  return normalize(forward_ + right_ * sx + up_ * sy);
}

}  // namespace rayline::trace
