// The ray order through cells ("a small top-level structure (cell bounds and ray
// order through cells) is always resident"): kd-restart traversal (Foley & Sugerman 2005)
// of the partition's kd-tree. Given a ray and the parameter where it stands, find the
// leaf cell it is in and the parameter where it leaves that cell.
//
// Every decision uses only t = (split - o[a]) / d[a] of the node planes, so a ray that
// leaves a cell at texit and restarts at tmin = texit lands in the next cell with an
// interval starting exactly at texit: successive cells tile the ray with no gap and no
// overlap (ray.hpp), whatever the number of blocks. The first and last cells' intervals
// extend to the ray's own tmin / tmax (see enter_cell).
#pragma once
#include <cstdint>

#include "render/partition/partition.hpp"

namespace rayline::trace {

struct CellSpan {
  std::uint32_t cell = 0;
  float tenter = 0, texit = 0;  // tenter < texit
};

// The cell the ray o + t·d occupies just after `tmin`, for t < tmax. False when the ray
// has left the scene bounds (or never meets them) before tmax.
bool enter_cell(const partition::BlockIndex& index, scene::Float3 o, scene::Float3 d, float tmin, float tmax,
                CellSpan& out);

// Empty-space skipping: false only when the segment o + t·d, t in [t0, t1], meets no set
// voxel of the block's occupancy grid (partition.hpp), so no triangle of the block can be
// hit there and the ray may go on to the next cell without the block being loaded: the
// image is the same (the skipped cell would have reported no hit), only fewer cell visits
// and loads. Conservative: voxels are grown by one around each triangle's bounds, the
// segment is clipped to the cell grown by one voxel and points outside the grid count in
// its border voxels, so float error smaller than a voxel can only answer true. True for a
// block without a grid.
bool segment_may_hit(const partition::BlockInfo& block, scene::Float3 o, scene::Float3 d, float t0, float t1);

}  // namespace rayline::trace
