#include "workload/path_trace_model.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "common/error.hpp"
#include "common/input_file.hpp"

namespace rayline {

namespace {
const char* kStageNames[] = {"entry", "intersect", "shade", "shadow"};
}

std::uint64_t SplitContext::key() const {
  if (client < 0 || client >= 1024 || frame < 0 || frame >= 65536 || tile < 0 || tile >= 4096 || bounce < 0 ||
      bounce >= 256 || block < 0 || block >= 65536)
    throw std::logic_error("split context out of the packable range");
  return (static_cast<std::uint64_t>(stage) << 62) | (static_cast<std::uint64_t>(client) << 52) |
         (static_cast<std::uint64_t>(frame) << 36) | (static_cast<std::uint64_t>(tile) << 24) |
         (static_cast<std::uint64_t>(bounce) << 16) | static_cast<std::uint64_t>(block);
}

bool parse_fidelity(const std::string& name, Fidelity& out) {
  if (name == "analytic") out = Fidelity::Analytic;
  else if (name == "markov") out = Fidelity::Markov;
  else if (name == "replay") out = Fidelity::Replay;
  else return false;
  return true;
}

const char* to_string(Fidelity f) {
  switch (f) {
    case Fidelity::Analytic: return "analytic";
    case Fidelity::Markov: return "markov";
    case Fidelity::Replay: return "replay";
  }
  return "?";
}

// ---- ReplayLog ------------------------------------------------------------------------

void ReplayLog::append(const SplitContext& ctx, std::uint64_t n, const std::vector<std::uint64_t>& out) {
  Group& g = groups_[ctx.key()];
  g.ctx = ctx;
  Piece p;
  p.n = n;
  if (g.remaining.size() < out.size()) g.remaining.resize(out.size(), 0);
  for (std::size_t i = 0; i < out.size(); ++i)
    if (out[i]) {
      p.out.emplace_back(static_cast<std::uint32_t>(i), out[i]);
      g.remaining[i] += out[i];
    }
  g.pieces.push_back(std::move(p));
  ++pieces_;
}

ReplayLog::Group* ReplayLog::find(const SplitContext& ctx) {
  auto it = groups_.find(ctx.key());
  return it == groups_.end() ? nullptr : &it->second;
}

void ReplayLog::freeze_templates() {
  if (templates_.empty()) templates_ = groups_;
}

ReplayLog::Group* ReplayLog::find_or_clone(const SplitContext& ctx, int keyframes) {
  if (Group* g = find(ctx)) return g;
  if (!per_keyframe_ || keyframes <= 0) return nullptr;
  SplitContext t = ctx;
  t.client = 0;
  t.frame = (ctx.client + ctx.frame) % keyframes;
  if (t.key() == ctx.key()) return nullptr;
  auto it = templates_.find(t.key());
  if (it == templates_.end()) return nullptr;
  Group& g = groups_[ctx.key()];
  g = it->second;
  g.ctx = ctx;
  return &g;
}

// One line per piece, in the order the groups' pieces were recorded:
//   STAGE CLIENT FRAME TILE BOUNCE BLOCK N CAT:COUNT ...
void ReplayLog::save(const std::string& path, const std::string& header) const {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << (per_keyframe_ ? "rayline-replay 1 per-keyframe\n" : "rayline-replay 1\n");
  if (!header.empty()) out << "# " << header << "\n";
  out << "# stage client frame tile bounce block rays category:count...\n";
  for (const auto& [key, g] : groups_)
    for (const Piece& p : g.pieces) {
      out << kStageNames[static_cast<int>(g.ctx.stage)] << ' ' << g.ctx.client << ' ' << g.ctx.frame << ' ' << g.ctx.tile
          << ' ' << g.ctx.bounce << ' ' << g.ctx.block << ' ' << p.n;
      for (const auto& [c, k] : p.out) out << ' ' << c << ':' << k;
      out << '\n';
    }
  // The last buffered bytes reach the file only on close: a full disk shows there.
  out.close();
  if (!out) throw std::runtime_error("cannot write " + path);
}

namespace {
// A whole token as an unsigned integer (no sign, no trailing characters).
template <class T>
bool parse_uint(std::string_view t, T& out) {
  if (t.empty() || t[0] == '-') return false;  // from_chars takes a sign for int
  const auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), out);
  return ec == std::errc() && p == t.data() + t.size();
}
}  // namespace

std::size_t outcome_categories(const SceneProfile& profile, RayStage stage, int block) {
  switch (stage) {
    case RayStage::Entry: return 1 + profile.blocks.size();
    case RayStage::Shade: return 2;
    case RayStage::Intersect:
    case RayStage::Shadow: return kFirstNeighbour + profile.blocks[static_cast<std::size_t>(block)].neighbours.size();
  }
  return 0;
}

ReplayLog ReplayLog::load(const std::string& path, const SceneProfile* profile) {
  std::ifstream in = open_input(path, "replay log");
  ReplayLog log;
  std::string line;
  int lineno = 0;
  if (!std::getline(in, line) || (line != "rayline-replay 1" && line != "rayline-replay 1 per-keyframe"))
    throw InputError(path, "line 1", "expected 'rayline-replay 1' (optionally followed by ' per-keyframe')");
  log.per_keyframe_ = line != "rayline-replay 1";
  ++lineno;
  std::vector<std::string> w;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.empty() || line[0] == '#') continue;
    const std::string f = "line " + std::to_string(lineno);
    std::istringstream ss(line);
    w.clear();
    for (std::string t; ss >> t;) w.push_back(std::move(t));
    SplitContext c;
    std::uint64_t n = 0;
    int* fields[] = {&c.client, &c.frame, &c.tile, &c.bounce, &c.block};
    bool ok = w.size() >= 7 && parse_uint(w[6], n);
    for (int k = 0; ok && k < 5; ++k) ok = parse_uint(w[static_cast<std::size_t>(k) + 1], *fields[k]);
    if (!ok) throw InputError(path, f, "malformed piece (expected STAGE CLIENT FRAME TILE BOUNCE BLOCK N CATEGORY:COUNT...)");
    int s = 0;
    while (s < 4 && w[0] != kStageNames[s]) ++s;
    if (s == 4) throw InputError(path, f, "unknown stage '" + w[0] + "'");
    c.stage = static_cast<RayStage>(s);
    try {
      (void)c.key();
    } catch (const std::logic_error&) {
      throw InputError(path, f, "context out of range");
    }
    // Against the profile it will replay (the model indexes its blocks and categories).
    std::size_t cats = 65537;
    if (profile) {
      if (c.stage != RayStage::Entry && static_cast<std::size_t>(c.block) >= profile->blocks.size())
        throw InputError(path, f, "block " + std::to_string(c.block) + " out of range: profile '" + profile->name + "' has " +
                                      std::to_string(profile->blocks.size()) + " blocks");
      cats = outcome_categories(*profile, c.stage, c.block);
    }
    std::vector<std::uint64_t> out;
    std::uint64_t sum = 0;
    for (std::size_t k = 7; k < w.size(); ++k) {
      const std::string& item = w[k];
      const auto colon = item.find(':');
      if (colon == std::string::npos) throw InputError(path, f, "expected CATEGORY:COUNT, got '" + item + "'");
      std::size_t cat = 0;
      std::uint64_t count = 0;
      if (!parse_uint(std::string_view(item).substr(0, colon), cat) || !parse_uint(std::string_view(item).substr(colon + 1), count))
        throw InputError(path, f, "bad count '" + item + "'");
      if (cat >= cats)
        throw InputError(path, f, "category " + std::to_string(cat) + " does not exist here (" + std::to_string(cats) +
                                      (profile ? " outcome categories for this stage and block in profile '" + profile->name + "')"
                                               : " at most)"));
      if (out.size() <= cat) out.resize(cat + 1, 0);
      if (count > std::numeric_limits<std::uint64_t>::max() - sum) throw InputError(path, f, "counts overflow");
      out[cat] += count;
      sum += count;
    }
    if (sum != n) throw InputError(path, f, "outcomes sum to " + std::to_string(sum) + ", not " + std::to_string(n));
    log.append(c, n, out);
  }
  return log;
}

// ---- RayFlowModel -----------------------------------------------------------------------

RayFlowModel::RayFlowModel(const SceneProfile& profile, Fidelity fidelity, std::uint64_t seed)
    : profile_(profile), fidelity_(fidelity), state_(seed * 0x9E3779B97F4A7C15ull + 0x5851F42D4C957F2Dull) {}

double RayFlowModel::uniform() {  // splitmix64 -> [0, 1)
  std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * (1.0 / 9007199254740992.0);
}

// Exact for small n or small mean (Bernoulli trials / pmf inversion), normal with a
// continuity correction otherwise; always in [0, n].
std::uint64_t RayFlowModel::binomial(std::uint64_t n, double p) {
  if (n == 0 || p <= 0) return 0;
  if (p >= 1) return n;
  if (n <= 32) {
    std::uint64_t k = 0;
    for (std::uint64_t i = 0; i < n; ++i) k += uniform() < p ? 1 : 0;
    return k;
  }
  const double nd = static_cast<double>(n);
  if (nd * p < 12 || nd * (1 - p) < 12) {
    const bool flip = nd * p >= 12;
    const double q = flip ? 1 - p : p;
    const double r = q / (1 - q);
    double pmf = std::pow(1 - q, nd), cdf = pmf;
    const double u = uniform();
    std::uint64_t k = 0;
    while (u > cdf && k < n) {
      pmf *= r * static_cast<double>(n - k) / static_cast<double>(k + 1);
      ++k;
      cdf += pmf;
      if (pmf < 1e-300 && cdf < u) break;
    }
    return flip ? n - k : k;
  }
  const double u1 = std::max(uniform(), 1e-300), u2 = uniform();
  const double z = std::sqrt(-2 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  const double x = std::floor(nd * p + std::sqrt(nd * p * (1 - p)) * z + 0.5);
  return static_cast<std::uint64_t>(std::clamp(x, 0.0, nd));
}

std::size_t RayFlowModel::categories(RayStage stage, int block) const { return outcome_categories(profile_, stage, block); }

void RayFlowModel::probabilities(const SplitContext& ctx, std::vector<double>& p) const {
  p.assign(categories(ctx.stage, ctx.block), 0.0);
  const bool analytic = fidelity_ == Fidelity::Analytic;
  const AnalyticParameters& a = profile_.analytic;
  if (ctx.stage == RayStage::Entry) {
    const CameraKey& key = profile_.camera_path[static_cast<std::size_t>(ctx.block) % profile_.camera_path.size()];
    p[0] = key.background;
    for (const auto& [b, pr] : key.entry) p[1 + static_cast<std::size_t>(b)] += pr;
    return;
  }
  if (ctx.stage == RayStage::Shade) {
    const double beta = analytic ? a.beta : profile_.blocks[static_cast<std::size_t>(ctx.block)].beta;
    p[kSurvive] = ctx.bounce + 1 >= profile_.max_bounces ? 0.0 : beta;
    p[kTerminate] = 1 - p[kSurvive];
    return;
  }
  const ProfileBlock& b = profile_.blocks[static_cast<std::size_t>(ctx.block)];
  double area = b.boundary_area;
  for (const ProfileNeighbour& n : b.neighbours) area += n.area;
  double nbr_area = 0;
  for (const ProfileNeighbour& n : b.neighbours) nbr_area += n.area;
  auto weight = [&](std::size_t i, double total) {
    if (!analytic) return b.neighbours[i].p;
    return total > 0 ? b.neighbours[i].area / total : 1.0 / static_cast<double>(b.neighbours.size());
  };
  if (ctx.stage == RayStage::Intersect) {
    // Sec. 5.2: n_a = (1 - alpha)|R| rays miss; analytic: they leave through the cell's faces
    // in proportion to area (boundary faces: escape).
    const double alpha = analytic ? a.alpha : b.alpha;
    const double miss = 1 - alpha;
    double escape = analytic ? (area > 0 ? b.boundary_area / area : 1.0) : b.escape;
    if (b.neighbours.empty()) escape = 1;
    p[kHit] = alpha;
    p[kEscape] = miss * escape;
    for (std::size_t i = 0; i < b.neighbours.size(); ++i)
      p[kFirstNeighbour + i] = miss * (1 - escape) * weight(i, analytic ? area - b.boundary_area : 0);
    return;
  }
  // Shadow rays: occluded here, or unoccluded and either on to a neighbour or at the light.
  const double occ = analytic ? a.shadow_occlusion : b.shadow_occlusion;
  const double exit = b.neighbours.empty() ? 0.0 : (analytic ? a.shadow_exit : b.shadow_exit);
  p[kOccluded] = occ;
  p[kLit] = (1 - occ) * (1 - exit);
  for (std::size_t i = 0; i < b.neighbours.size(); ++i)
    p[kFirstNeighbour + i] = (1 - occ) * exit * weight(i, nbr_area);
}

void RayFlowModel::sample(const std::vector<double>& p, std::uint64_t n, std::vector<std::uint64_t>& out) {
  out.assign(p.size(), 0);
  double mass = 0;
  for (double x : p) mass += x;
  std::uint64_t left = n;
  // The last category with probability takes the rest (exact conservation).
  std::size_t last = p.size();
  while (last > 0 && p[last - 1] <= 0) --last;
  for (std::size_t i = 0; i < p.size() && left > 0; ++i) {
    if (p[i] <= 0) continue;
    const std::uint64_t k = i + 1 == last ? left : binomial(left, std::min(1.0, p[i] / mass));
    out[i] = k;
    left -= k;
    mass -= p[i];
    if (mass <= 0) break;
  }
  if (left > 0) {  // rounding left mass ~0: give the rest to the most likely category
    const auto best = static_cast<std::size_t>(std::max_element(p.begin(), p.end()) - p.begin());
    out[best] += left;
  }
}

// Replay: the next recorded piece of this context when it has the same size (so the same
// batching reproduces every job exactly); otherwise a proportional share (largest
// remainder) of what the context still has, so the per-context totals of a frame stay
// exact whatever the batching; rays beyond the record come from the Markov model.
void RayFlowModel::replay(const SplitContext& ctx, std::uint64_t n, std::vector<std::uint64_t>& out) {
  const std::size_t cats = categories(ctx.stage, ctx.block);
  out.assign(cats, 0);
  ReplayLog::Group* g = replay_ ? replay_->find_or_clone(ctx, static_cast<int>(profile_.camera_path.size())) : nullptr;
  std::uint64_t have = 0;
  if (g) {
    if (g->remaining.size() > cats) throw InputError("--replay", "", "a recorded category does not exist in this profile");
    g->remaining.resize(cats, 0);
    for (std::uint64_t x : g->remaining) have += x;
  }
  if (g && !g->pieces.empty() && g->pieces.front().n == n) {
    for (const auto& [c, k] : g->pieces.front().out) {
      out[c] += k;
      g->remaining[c] -= k;
    }
    g->pieces.pop_front();
    replayed_ += n;
    ++exact_pieces_;
    return;
  }
  // Batching differs from the recording: the outcomes of the context's next `take` recorded
  // rays, in recorded order (whole pieces, then a largest-remainder share of the piece that
  // is split). Following the recorded order keeps causality where contexts feed each other
  // (rays crossing between two cells in both directions at one bounce); the context's
  // totals stay exact whenever its inflow is.
  const std::uint64_t take = std::min(n, have);
  std::uint64_t need = take;
  while (need > 0 && g && !g->pieces.empty()) {
    ReplayLog::Piece& p = g->pieces.front();
    if (p.n <= need) {
      for (const auto& [c, k] : p.out) {
        out[c] += k;
        g->remaining[c] -= k;
      }
      need -= p.n;
      g->pieces.pop_front();
      continue;
    }
    std::vector<std::pair<double, std::size_t>> frac;
    std::vector<std::uint64_t> part(p.out.size(), 0);
    std::uint64_t given = 0;
    for (std::size_t i = 0; i < p.out.size(); ++i) {
      const long double share = static_cast<long double>(p.out[i].second) * need / p.n;
      part[i] = static_cast<std::uint64_t>(share);
      given += part[i];
      frac.emplace_back(-static_cast<double>(share - static_cast<long double>(part[i])), i);
    }
    std::sort(frac.begin(), frac.end());
    for (std::size_t k = 0; given < need; ++k)
      if (part[frac[k % frac.size()].second] < p.out[frac[k % frac.size()].second].second) {
        ++part[frac[k % frac.size()].second];
        ++given;
      }
    for (std::size_t i = 0; i < p.out.size(); ++i) {
      out[p.out[i].first] += part[i];
      g->remaining[p.out[i].first] -= part[i];
      p.out[i].second -= part[i];
    }
    p.n -= need;
    need = 0;
  }
  replayed_ += take;
  if (take < n) {
    fallback_ += n - take;
    probabilities(ctx, p_);
    p_cached_ = false;
    std::vector<std::uint64_t> extra;
    sample(p_, n - take, extra);
    for (std::size_t i = 0; i < cats; ++i) out[i] += extra[i];
  }
}

void RayFlowModel::split(const SplitContext& ctx, std::uint64_t n, std::vector<std::uint64_t>& out) {
  if (fidelity_ == Fidelity::Replay) {
    replay(ctx, n, out);
  } else {
    // A job's keys share stage and block (and Shade's probabilities also depend on the
    // bounce): consecutive splits mostly reuse the last probabilities.
    const int bounce = ctx.stage == RayStage::Shade ? ctx.bounce : -1;
    if (!p_cached_ || ctx.stage != p_stage_ || ctx.block != p_block_ || bounce != p_bounce_) {
      probabilities(ctx, p_);
      p_cached_ = true;
      p_stage_ = ctx.stage;
      p_block_ = ctx.block;
      p_bounce_ = bounce;
    }
    sample(p_, n, out);
  }
  if (record_) record_->append(ctx, n, out);
}

}  // namespace rayline
