// A ray log: what every ray of one render did, recorded by `rayline render --record-twin`
// (render/engine/ray_log_recorder.hpp) and replayed by the simulated twin
// (workload/render_twin.hpp, docs/validation.md). The renderer's rays are deterministic:
// each is keyed by (seed, pixel, sample, hit, purpose), so what a ray does in a cell does
// not depend on how rays were batched into jobs, which device traced them or when. The log
// is therefore an exact oracle for any batching and any schedule of the same scene,
// camera, resolution, spp, path length and seed.
//
// A visit is one ray in one cell (one E-job's worth of work for that ray). Its children
// are the rays it handed on: the same ray in the next cell after a miss, or after a hit a
// shadow ray and a continuation, each in the cell where it starts. A visit without
// children ended there (hit without continuation, occluded, or left the scene). Camera
// ray i (pixel i % pixels, sample i / pixels) starts at entry[i], or nowhere when it
// missed every cell.
//
// File format (little-endian, docs/validation.md): "RAYLOG01", then u32 width, height,
// spp, cells; u64 camera rays, visits, children; the entry array (u32 each), the visits
// (cell u32, first child u32, bounce u16, kind u8, child count u8) and the children (u32).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace rayline {

struct RayVisit {
  std::uint32_t cell = 0;
  std::uint32_t first = 0;     // index of its first child in RayLog::children
  std::uint16_t bounce = 0;    // surface hits so far along its path
  std::uint8_t kind = 0;       // 0 path ray, 1 shadow ray
  std::uint8_t children = 0;   // 0: the ray ended in this cell
};

struct RayLog {
  static constexpr std::uint32_t kNoVisit = 0xFFFFFFFFu;
  std::uint32_t width = 0, height = 0, spp = 0, cells = 0;
  std::vector<std::uint32_t> entry;      // camera ray -> its first visit, or kNoVisit
  std::vector<RayVisit> visits;
  std::vector<std::uint32_t> children;   // visit ids

  std::uint64_t camera_rays() const { return entry.size(); }

  // Written to `path` as is (the caller stages and renames); std::runtime_error naming
  // the file when it cannot be written.
  void save(const std::string& path) const;
  // InputError naming the file and the field on a bad or truncated file, or on a visit,
  // child or entry out of range.
  static RayLog load(const std::string& path);
};

}  // namespace rayline
