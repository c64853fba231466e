// The ray record of ray batching (Sec. 3.1, 5.1): what a RayQueue_b / ShadowRayQueue_b
// holds. 64 bytes, the size the timing model charges per ray (docs/architecture.md: 32–64 bytes).
//
// A ray walks the kd-tree cells front to back (cell_walk.hpp). `tnear`/`texit` are the
// interval of the current cell: a hit with t in (tnear, texit] is final because cells
// never overlap, so a miss continues in the next cell starting exactly at texit (the
// intervals of successive cells tile the ray; nothing is missed or found twice).
#pragma once
#include <cstdint>

#include "render/scene/geometry.hpp"

namespace rayline::trace {

using scene::Float3;

enum class RayKind : std::uint8_t { Path = 0, Shadow = 1 };

struct RayRecord {
  Float3 org;
  float tnear = 0;      // entry of the current cell
  Float3 dir;
  float tfar = 0;       // end of the ray (infinity for path rays, the light for shadow rays)
  Float3 weight;        // path throughput (Path) or the radiance it carries if unoccluded (Shadow)
  std::uint32_t pixel = 0;
  std::uint32_t sample = 0;
  std::uint16_t bounce = 0;  // surface hits so far along the path
  RayKind kind = RayKind::Path;
  std::uint8_t flags = 0;
  std::uint32_t cell = 0;    // the block whose queue holds it
  float texit = 0;           // exit of the current cell
};
static_assert(sizeof(RayRecord) == 64, "the timing model charges 64 bytes per ray");

// RayRecord::flags bits. Bit 0 is path_kernels.cpp's "first cell". kRayCpuOnly: a GPU E-job
// found the ray doubtful (render/vulkan/README.md, "Doubtful rays") and hands it back to its
// cell's queue for a CPU device, so Embree decides it as in a CPU-only render; every ray a
// kernel makes (continuation, shadow, next cell) starts with the bit clear.
inline constexpr std::uint8_t kRayCpuOnly = 2;

}  // namespace rayline::trace
