// Per-cell ray statistics and replay logs recorded from the real renderer: the
// data behind the simulator's Markov and replay fidelity levels (docs/scene-profiles.md),
// taken from the renderer's own kernels instead of a synthetic tracer.
//
// With a recorder, the renderer runs each CPU E-job's kernel one ray at a time (the same
// ray_intersect / shadow_intersect, so the image is unchanged) and classifies every ray
// by what the kernel did with it. Outcomes are mapped onto the simulator's job graph
// (workload/path_trace_model.hpp, Fig. 3), which has a separate Shade stage and exactly one
// shadow ray per hit, on the hit's block:
//   * path ray in cell b, bounce k, tile t -> Intersect(t, k, b): hit | escape | neighbour n;
//   * a hit -> Shade(t, k, b): survive (a continuation was created) | terminate;
//   * the hit's shadow ray -> Shadow(t, k, b) (the simulator keys shadow rays by the hit's
//     bounce; the renderer's shadow ray has bounce k + 1). Where the renderer made no
//     shadow ray (light behind the surface, black albedo or contribution) the simulator's
//     ray is counted `occluded` in b; one that started in a neighbour c is counted as
//     leaving b for c; one that ended at once is `lit`;
//   * a continuation that started in a neighbour c is one more Intersect(t, k+1, b) ray
//     leaving b for c (the simulator puts survivors on b); one that left the scene at once
//     is one more Intersect(t, k+1, b) ray escaping;
//   * a ray that leaves b for a cell d that is not a face neighbour (it crossed an edge
//     or corner) goes b -> n -> d through a face neighbour n of both (one more Intersect /
//     Shadow ray on n); where there is none it is counted `escape`/`lit` on b and in
//     `non_face_unrouted` (a context then holds more recorded rays than flow into it);
//   * camera rays -> Entry(t, keyframe): background | first cell.
// With this mapping the recorded outcomes form a closed flow: every ray a context sends
// on is recorded as an input of the context it reaches, so replaying the log gives every
// context exactly its recorded total (the per-piece batching of the simulator differs).
//
// Thread safety: trace_job runs on worker threads; its counts are kept per job and merged
// under a mutex when the job's kernel ends. camera_rays runs on the loop thread.
#pragma once
#include <cstdint>
#include <map>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "render/embree/block_geometry.hpp"
#include "render/integrator/path_kernels.hpp"
#include "render/partition/partition.hpp"
#include "workload/path_trace_model.hpp"
#include "workload/scene_profile.hpp"

namespace rayline::engine {

struct ProfileRecorderOptions {
  int width = 0, height = 0, spp = 1, max_depth = 5;  // set by begin()
  int tiles_x = 8, tiles_y = 8;  // the replay log's tile grid (the profile's image.tiles)
  int keyframe = 0;              // camera keyframe: Entry context block, and the log's frame
  bool replay = false;           // also keep a replay log (one piece per job and context)
};

class ProfileRecorder {
 public:
  explicit ProfileRecorder(ProfileRecorderOptions opt) : opt_(opt) {}
  // Called by render() once the partition and image are known (throws std::invalid_argument
  // when the tile grid does not fit the image).
  void begin(const partition::BlockIndex& index, int width, int height, int spp, int max_depth);

  // Camera rays with indices [first, first + n) (pixel = i % pixels) were generated;
  // `placed` holds those that entered a cell (the others missed the scene).
  void camera_rays(std::span<const trace::RayRecord> placed, std::uint64_t first, std::uint64_t n, std::uint64_t pixels);
  // Runs the kernel of an E-job in `cell` ray by ray into `out` / `counts` (as
  // ray_intersect / shadow_intersect over `rays` would) and records every ray's outcome.
  void trace_job(const trace::TraceSettings& ts, const trace::BlockGeometry& geo, std::uint32_t cell,
                 std::span<const trace::RayRecord> rays, std::vector<trace::RayRecord>& out, trace::RayCounts& counts);

  // Totals per (stage, block): dense outcome counts (categories of workload/path_trace_model.hpp).
  const std::vector<std::uint64_t>& totals(RayStage stage, std::uint32_t block) const;
  std::uint64_t camera_total() const { return camera_total_; }
  const std::vector<std::uint64_t>& entry() const { return entry_; }  // [background, cell 0..]
  const ReplayLog& replay() const { return log_; }
  const ProfileRecorderOptions& options() const { return opt_; }

  // How the renderer's rays were mapped onto the simulator's graph (see the top).
  struct Mapping {
    std::uint64_t shadow_not_created = 0, shadow_started_in_neighbour = 0, shadow_ended_at_once = 0;
    std::uint64_t continuation_started_in_neighbour = 0, continuation_escaped_at_once = 0;
    std::uint64_t non_face_routed = 0, non_face_unrouted = 0;
    std::uint64_t path_rays_traced = 0, shadow_rays_traced = 0;
  };
  Mapping mapping() const;

  // The statistics as JSON ("rayline-render-statistics", docs/scene-profiles.md); `extra`
  // is spliced in as more top-level members (e.g. "\"scene\": \"x\"").
  std::string statistics_json(const std::string& extra = "") const;
  // A scene profile (Markov statistics, no prior) of this render's partition and image:
  // block bytes `bytes[b]`, neighbours and areas from the block index.
  SceneProfile to_profile(const std::vector<Bytes>& bytes) const;

  int tile_of(std::uint32_t pixel) const;

 private:
  struct Tally {
    std::map<std::uint64_t, std::pair<SplitContext, std::vector<std::uint64_t>>> ctx;
    Mapping m;
  };
  std::size_t categories(RayStage stage, std::uint32_t block) const;
  int neighbour_index(std::uint32_t b, std::uint32_t n) const;  // -1: not a face neighbour
  void add(Tally& t, RayStage stage, int tile, int bounce, std::uint32_t block, std::size_t category) const;
  // A ray of (stage, tile, bounce) leaves b for cell d (routed through a common neighbour).
  void move(Tally& t, RayStage stage, int tile, int bounce, std::uint32_t b, std::uint32_t d) const;
  void merge(Tally& t);

  partition::BlockIndex index_;
  ProfileRecorderOptions opt_;
  std::vector<std::vector<std::uint32_t>> nbr_;  // face neighbours per block, sorted (profile order)
  mutable std::mutex mu_;
  std::vector<std::vector<std::uint64_t>> totals_[4];
  std::vector<std::uint64_t> entry_;
  std::uint64_t camera_total_ = 0;
  Mapping mapping_;
  ReplayLog log_;
};

}  // namespace rayline::engine
