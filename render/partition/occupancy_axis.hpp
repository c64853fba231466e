// The per-axis arithmetic that an occupancy grid (partition.hpp, BlockInfo::occupancy)
// shares between the partitioner, which sets voxels, and the cell walk, which tests them
// (cell_walk.hpp, segment_may_hit).
//
// A grid resolves an axis only when both the voxel width ext / R and its inverse R / ext
// are finite and non-zero. A cell that is flat along the axis, or so thin that R / ext
// overflows (extents below about 1e-37: 0 × ∞ would then turn coordinates into NaN), or so
// wide that ext is not finite, is one column along that axis: mark_occupancy sets every
// voxel along it and segment_may_hit does not decide (the cell is visited), so empty-space
// skipping stays conservative.
#pragma once
#include <algorithm>
#include <cmath>

namespace rayline::partition {

inline bool occupancy_axis_resolved(float ext, int resolution) {
  const float r = float(resolution);
  return ext > 0 && std::isfinite(ext) && std::isfinite(r / ext) && ext / r > 0;
}

// The voxel index floor-coordinate `f` falls in, clamped to [0, resolution − 1]; a NaN
// (which no finite cell and triangle produce) maps to `if_nan`, never to an int cast of NaN.
inline int occupancy_voxel(float f, int resolution, int if_nan) {
  if (std::isnan(f)) return if_nan;
  return int(std::clamp(f, 0.0f, float(resolution - 1)));
}

}  // namespace rayline::partition
