// Clients of the path-tracing workload (Sec. 6): "a number of client processes ...
// request a scene along predefined camera movements, feeding an image request in a
// frame-by-frame manner". Each client keeps `frames_in_flight` frames requested (one by
// default): a frame's primary rays are generated in waves (GenerateRays jobs) while the
// frame has fewer than `inflight_rays` rays alive, and the client's next frame is
// requested when AdditiveCompose has delivered one. Frame f of client c uses camera keyframe (c + f) mod K, so
// clients look at different parts of the scene.
//
// Pixel accounting (conservation without per-ray state): a frame is tiles_x x tiles_y
// tiles; a frame's primary samples are units (pass s, tile t) of tile_pixels(t) rays, in
// pass-major order; a wave is a run of consecutive units of about wave_rays rays.
// Replay fidelity carries every count per (frame, tile, bounce), since its recorded
// outcomes are per tile, and checks "every pixel gets spp samples" exactly per tile. In
// the Markov and analytic models a ray's outcome does not depend on its tile, so counts
// carry (frame, bounce) only (tile 0 in the key: 64x fewer keys on a museum frame) and
// the check is exact for the frame's total; partial framebuffers are sized from the
// expected tile coverage of the samples accumulated there (partial_tiles).
#pragma once
#include <cstdint>
#include <map>
#include <vector>

#include "workload/scene_profile.hpp"
#include "sched/core/types.hpp"

namespace rayline {

// A count of rays (or samples) per key; keys pack (frame uid, tile, bounce). Sorted.
using RayCounts = std::vector<std::pair<std::uint64_t, std::uint64_t>>;
inline std::uint64_t ray_key(std::uint32_t frame, int tile, int bounce) {
  return (static_cast<std::uint64_t>(frame) << 20) | (static_cast<std::uint64_t>(tile) << 8) | static_cast<std::uint64_t>(bounce);
}
inline std::uint32_t key_frame(std::uint64_t k) { return static_cast<std::uint32_t>(k >> 20); }
inline int key_tile(std::uint64_t k) { return static_cast<int>((k >> 8) & 0xFFF); }
inline int key_bounce(std::uint64_t k) { return static_cast<int>(k & 0xFF); }
std::uint64_t total(const RayCounts& c);
void merge_into(RayCounts& into, const RayCounts& add);  // keeps keys sorted, sums counts
void add_count(RayCounts& c, std::uint64_t key, std::uint64_t n);  // append-or-add (any order; call normalize after)
void normalize(RayCounts& c);

struct FrameState {
  int client = 0;
  int index = 0;                     // along the client's camera path
  int keyframe = 0;
  std::uint64_t units_total = 0, next_unit = 0;
  int generate_pending = 0;          // GenerateRays jobs not finished
  std::uint64_t alive = 0;           // rays and hit records not yet ended (incl. unissued waves' none)
  std::uint64_t records_pending = 0; // sample records not yet accumulated
  std::map<MemId, std::vector<std::uint64_t>> partial;  // per memory: samples per tile accumulated there
  bool composing = false, delivered = false;
  bool abandoned = false;            // work lost with a failed device: asked for again
  Time requested = 0, delivered_at = 0;
  std::vector<std::uint64_t> delivered_samples;  // per tile, summed over the partial framebuffers
};

struct ClientState {
  MemId memory = kNone;       // where its framebuffer is (the compose destination)
  std::int32_t framebuffer = kNone;  // BlockId of its framebuffer
  std::vector<std::int64_t> frames;  // uids of its frames in flight (indices into frames), oldest first
  int frames_done = 0;
  int next_index = 0;         // the next frame along its camera path
};

// The next wave of a frame: ray counts at bounce 0, per tile (per_tile) or one count
// under tile 0, advancing next_unit.
RayCounts next_wave(const SceneProfile& p, std::uint32_t frame_uid, FrameState& f, bool per_tile);

// Tiles a partial framebuffer of `samples` samples covers when its samples carry no tile:
// the expected number of tiles hit by that many samples spread uniformly over the image,
// tiles * (1 - (1 - 1/tiles)^samples), rounded up, at most `tiles`.
std::uint64_t partial_tiles(std::uint64_t samples, int tiles);

}  // namespace rayline
