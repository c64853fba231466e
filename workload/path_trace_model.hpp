// The ray-flow model behind the path-tracing workload: where the rays of a batch go when
// a job of Fig. 3 processes them, at one of three fidelity levels (docs/architecture.md "Workload"):
//   * analytic — the paper's own assumptions (Sec. 5.2): one alpha, beta, shadow
//     occlusion for the whole scene; missed rays leave the cell through its faces in
//     proportion to their area (shared faces: to that neighbour; boundary faces: escape);
//   * markov   — per-block alpha, beta, escape, shadow statistics and neighbour
//     transition probabilities, fitted from traced paths (scene profile);
//   * replay   — outcome counts recorded from a render (a ReplayLog), replayed exactly.
// Rays are never simulated one by one: a batch is a set of counts per (client, frame,
// tile, bounce), and each count is split over the outcome categories of its stage
// (multinomially, from the workload's deterministic generator, or from the log). Every
// split conserves its input exactly (integers), which is what makes the conservation test
// exact.
#pragma once
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "workload/scene_profile.hpp"

namespace rayline {

// Outcome categories per stage (index order of the split vector):
//   Entry     (GenerateRays; `block` = camera keyframe): [background, block 0 .. B-1]
//   Intersect (RayIntersect on `block`): [hit, escape, neighbour 0 .. k-1 (profile order)]
//   Shade     (Shade of hits on `block`): [terminate, survive]
//   Shadow    (ShadowIntersect on `block`): [occluded, reaches light, neighbour 0 .. k-1]
enum class RayStage : std::uint8_t { Entry, Intersect, Shade, Shadow };
inline constexpr int kHit = 0, kEscape = 1, kTerminate = 0, kSurvive = 1, kOccluded = 0, kLit = 1, kFirstNeighbour = 2;

struct SplitContext {
  RayStage stage = RayStage::Intersect;
  int client = 0, frame = 0;  // frame: index along the client's camera path
  int tile = 0, bounce = 0;
  int block = 0;
  std::uint64_t key() const;  // packed (stage, client < 1024, frame < 65536, tile < 4096, bounce < 256, block < 65536)
};

// The number of outcome categories of a stage on a block (the table above).
std::size_t outcome_categories(const SceneProfile& profile, RayStage stage, int block);

enum class Fidelity : std::uint8_t { Analytic, Markov, Replay };
bool parse_fidelity(const std::string& name, Fidelity& out);
const char* to_string(Fidelity f);

// Recorded outcome counts (the replay format; docs/scene-profiles.md "Replay logs"). Per
// context, the pieces in the order the recording processed them: (rays in, outcome counts).
class ReplayLog {
 public:
  struct Piece {
    std::uint64_t n = 0;
    std::vector<std::pair<std::uint32_t, std::uint64_t>> out;  // sparse (category, count)
  };
  struct Group {
    SplitContext ctx;
    std::deque<Piece> pieces;                 // not yet replayed, in recorded order
    std::vector<std::uint64_t> remaining;     // dense, categories not yet handed out
  };
  void append(const SplitContext& ctx, std::uint64_t n, const std::vector<std::uint64_t>& out);
  Group* find(const SplitContext& ctx);
  // Per-keyframe logs (written by `rayline render --record-replay`, first line
  // "rayline-replay 1 per-keyframe"): they hold one frame per camera keyframe k, as client
  // 0's frame k. Any other (client c, frame f) replays a fresh copy of the recording of its
  // keyframe (c + f) mod `keyframes` (see find_or_clone). Other logs: exact contexts only.
  bool per_keyframe() const { return per_keyframe_; }
  void set_per_keyframe(bool on) { per_keyframe_ = on; }
  // Copies the groups as recorded (before any replay): the sources of find_or_clone.
  void freeze_templates();
  Group* find_or_clone(const SplitContext& ctx, int keyframes);
  std::size_t groups() const { return groups_.size(); }
  std::size_t pieces() const { return pieces_; }
  void save(const std::string& path, const std::string& header) const;  // text, written as is
  // InputError on bad lines; with `profile`, also on a block or category it does not have
  // (the log is replayed against it).
  static ReplayLog load(const std::string& path, const SceneProfile* profile = nullptr);

 private:
  std::map<std::uint64_t, Group> groups_;
  std::map<std::uint64_t, Group> templates_;
  std::size_t pieces_ = 0;
  bool per_keyframe_ = false;
};

class RayFlowModel {
 public:
  RayFlowModel(const SceneProfile& profile, Fidelity fidelity, std::uint64_t seed);
  void set_replay(std::shared_ptr<ReplayLog> log) {
    replay_ = std::move(log);
    if (replay_ && replay_->per_keyframe()) replay_->freeze_templates();
  }
  void record_to(ReplayLog* log) { record_ = log; }
  Fidelity fidelity() const { return fidelity_; }

  std::size_t categories(RayStage stage, int block) const;
  // Splits n rays of context ctx over its categories; `out` is resized, sums to n.
  void split(const SplitContext& ctx, std::uint64_t n, std::vector<std::uint64_t>& out);
  // The model's probabilities (analytic or Markov; replay falls back to Markov).
  void probabilities(const SplitContext& ctx, std::vector<double>& p) const;

  std::uint64_t replayed_rays() const { return replayed_; }      // taken from the log
  std::uint64_t fallback_rays() const { return fallback_; }      // replay: not in the log
  std::uint64_t exact_pieces() const { return exact_pieces_; }   // replay: recorded piece matched

 private:
  double uniform();
  std::uint64_t binomial(std::uint64_t n, double p);
  void sample(const std::vector<double>& p, std::uint64_t n, std::vector<std::uint64_t>& out);
  void replay(const SplitContext& ctx, std::uint64_t n, std::vector<std::uint64_t>& out);

  const SceneProfile& profile_;
  Fidelity fidelity_;
  std::uint64_t state_;
  std::shared_ptr<ReplayLog> replay_;
  ReplayLog* record_ = nullptr;
  std::vector<double> p_;
  bool p_cached_ = false;  // p_ holds probabilities(stage, block, bounce) below
  RayStage p_stage_{};
  int p_block_ = -1, p_bounce_ = -1;
  std::uint64_t replayed_ = 0, fallback_ = 0, exact_pieces_ = 0;
};

}  // namespace rayline
