#include "render/engine/profile_recorder.hpp"

#include <algorithm>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "render/embree/embree_kernels.hpp"

namespace rayline::engine {

using trace::RayCounts;
using trace::RayKind;
using trace::RayRecord;

void ProfileRecorder::begin(const partition::BlockIndex& index, int width, int height, int spp, int max_depth) {
  index_ = index;
  log_.set_per_keyframe(true);  // one frame per camera keyframe (client 0, frame = keyframe)
  opt_.width = width, opt_.height = height, opt_.spp = spp, opt_.max_depth = max_depth;
  if (opt_.width <= 0 || opt_.height <= 0) throw std::invalid_argument("profile recorder: image size not set");
  if (opt_.tiles_x < 1 || opt_.tiles_y < 1 || opt_.tiles_x > opt_.width || opt_.tiles_y > opt_.height ||
      opt_.tiles_x * opt_.tiles_y > 4096)
    throw std::invalid_argument("profile recorder: tiles must fit the image (at most 4096)");
  const std::size_t nb = index.blocks.size();
  nbr_.resize(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    for (const auto& n : index.blocks[b].neighbours) nbr_[b].push_back(n.block);
    std::sort(nbr_[b].begin(), nbr_[b].end());
  }
  for (int s = 0; s < 4; ++s) {
    totals_[s].resize(nb);
    for (std::size_t b = 0; b < nb; ++b)
      totals_[s][b].assign(categories(static_cast<RayStage>(s), static_cast<std::uint32_t>(b)), 0);
  }
  entry_.assign(1 + nb, 0);
}

std::size_t ProfileRecorder::categories(RayStage stage, std::uint32_t block) const {
  switch (stage) {
    case RayStage::Entry: return 1 + nbr_.size();
    case RayStage::Shade: return 2;
    default: return kFirstNeighbour + nbr_[block].size();
  }
}

int ProfileRecorder::tile_of(std::uint32_t pixel) const {
  const int x = static_cast<int>(pixel % static_cast<std::uint32_t>(opt_.width));
  const int y = static_cast<int>(pixel / static_cast<std::uint32_t>(opt_.width));
  const int w0 = opt_.width / opt_.tiles_x, h0 = opt_.height / opt_.tiles_y;
  const int tx = std::min(x / w0, opt_.tiles_x - 1), ty = std::min(y / h0, opt_.tiles_y - 1);
  return ty * opt_.tiles_x + tx;
}

int ProfileRecorder::neighbour_index(std::uint32_t b, std::uint32_t n) const {
  const auto& v = nbr_[b];
  const auto it = std::lower_bound(v.begin(), v.end(), n);
  return it != v.end() && *it == n ? static_cast<int>(it - v.begin()) : -1;
}

void ProfileRecorder::add(Tally& t, RayStage stage, int tile, int bounce, std::uint32_t block, std::size_t cat) const {
  SplitContext c;
  c.stage = stage;
  c.client = 0;
  c.frame = opt_.keyframe;
  c.tile = tile;
  c.bounce = bounce;
  c.block = static_cast<int>(block);
  auto [it, fresh] = t.ctx.try_emplace(c.key());
  if (fresh) {
    it->second.first = c;
    it->second.second.assign(categories(stage, block), 0);
  }
  ++it->second.second[cat];
}

void ProfileRecorder::move(Tally& t, RayStage stage, int tile, int bounce, std::uint32_t b, std::uint32_t d) const {
  if (const int i = neighbour_index(b, d); i >= 0) {
    add(t, stage, tile, bounce, b, static_cast<std::size_t>(kFirstNeighbour + i));
    return;
  }
  // Not a face neighbour (an edge / corner crossing): through a face neighbour of both.
  for (std::uint32_t n : nbr_[b]) {
    const int j = neighbour_index(n, d);
    if (j < 0) continue;
    add(t, stage, tile, bounce, b, static_cast<std::size_t>(kFirstNeighbour + neighbour_index(b, n)));
    add(t, stage, tile, bounce, n, static_cast<std::size_t>(kFirstNeighbour + j));
    ++t.m.non_face_routed;
    return;
  }
  add(t, stage, tile, bounce, b, kEscape);  // == kLit for shadow rays
  ++t.m.non_face_unrouted;
}

void ProfileRecorder::camera_rays(std::span<const RayRecord> placed, std::uint64_t first, std::uint64_t n,
                                  std::uint64_t pixels) {
  const int tiles = opt_.tiles_x * opt_.tiles_y;
  const std::size_t nb = nbr_.size();
  // Per tile: [background, cell 0..B-1]; start with every ray as background.
  std::vector<std::vector<std::uint64_t>> per(static_cast<std::size_t>(tiles));
  for (std::uint64_t i = first; i < first + n; ++i) {
    auto& v = per[static_cast<std::size_t>(tile_of(static_cast<std::uint32_t>(i % pixels)))];
    if (v.empty()) v.assign(1 + nb, 0);
    ++v[0];
  }
  for (const RayRecord& r : placed) {
    auto& v = per[static_cast<std::size_t>(tile_of(r.pixel))];
    --v[0];
    ++v[1 + r.cell];
  }
  std::lock_guard<std::mutex> lock(mu_);
  camera_total_ += n;
  for (int t = 0; t < tiles; ++t) {
    const auto& v = per[static_cast<std::size_t>(t)];
    if (v.empty()) continue;
    std::uint64_t sum = 0;
    for (std::size_t k = 0; k < v.size(); ++k) entry_[k] += v[k], sum += v[k];
    if (opt_.replay) {
      SplitContext c;
      c.stage = RayStage::Entry;
      c.frame = opt_.keyframe;
      c.tile = t;
      c.block = opt_.keyframe;
      log_.append(c, sum, v);
    }
  }
}

void ProfileRecorder::trace_job(const trace::TraceSettings& ts, const trace::BlockGeometry& geo, std::uint32_t cell,
                                std::span<const RayRecord> rays, std::vector<RayRecord>& out, RayCounts& counts) {
  Tally t;
  const std::uint32_t b = cell;
  for (const RayRecord& r : rays) {
    RayCounts c;
    const std::size_t before = out.size();
    const int tile = tile_of(r.pixel);
    if (r.kind == RayKind::Path) {
      trace::ray_intersect(ts, geo, std::span<const RayRecord>(&r, 1), out, c);
      ++t.m.path_rays_traced;
      const int k = r.bounce;
      if (c.terminated > 0) {  // a hit: shaded here (every hit ends its ray exactly once)
        add(t, RayStage::Intersect, tile, k, b, kHit);
        const bool survived = c.paths_ended == c.escaped;  // no path ended, or only its fresh continuation escaped
        add(t, RayStage::Shade, tile, k, b, survived ? kSurvive : kTerminate);
        const RayRecord* shadow = nullptr;
        const RayRecord* cont = nullptr;
        for (std::size_t i = before; i < out.size(); ++i)
          (out[i].kind == RayKind::Shadow ? shadow : cont) = &out[i];
        if (shadow) {
          if (shadow->cell != b) {
            move(t, RayStage::Shadow, tile, k, b, shadow->cell);
            ++t.m.shadow_started_in_neighbour;
          }
        } else if (c.unoccluded > 0) {
          add(t, RayStage::Shadow, tile, k, b, kLit);
          ++t.m.shadow_ended_at_once;
        } else {
          add(t, RayStage::Shadow, tile, k, b, kOccluded);
          ++t.m.shadow_not_created;
        }
        if (survived) {
          if (!cont) {
            add(t, RayStage::Intersect, tile, k + 1, b, kEscape);
            ++t.m.continuation_escaped_at_once;
          } else if (cont->cell != b) {
            move(t, RayStage::Intersect, tile, k + 1, b, cont->cell);
            ++t.m.continuation_started_in_neighbour;
          }
        }
      } else if (out.size() > before) {
        move(t, RayStage::Intersect, tile, k, b, out.back().cell);
      } else {
        add(t, RayStage::Intersect, tile, k, b, kEscape);
      }
    } else {
      trace::shadow_intersect(ts, geo, std::span<const RayRecord>(&r, 1), out, c);
      ++t.m.shadow_rays_traced;
      const int k = std::max(0, int(r.bounce) - 1);  // keyed by the bounce of the hit that made it
      if (c.occluded > 0) add(t, RayStage::Shadow, tile, k, b, kOccluded);
      else if (out.size() > before) move(t, RayStage::Shadow, tile, k, b, out.back().cell);
      else add(t, RayStage::Shadow, tile, k, b, kLit);
    }
    counts += c;
  }
  merge(t);
}

void ProfileRecorder::merge(Tally& t) {
  std::lock_guard<std::mutex> lock(mu_);
  for (auto& [key, cv] : t.ctx) {
    const SplitContext& c = cv.first;
    auto& tot = totals_[static_cast<int>(c.stage)][static_cast<std::size_t>(c.block)];
    std::uint64_t n = 0;
    for (std::size_t i = 0; i < cv.second.size(); ++i) tot[i] += cv.second[i], n += cv.second[i];
    if (opt_.replay) log_.append(c, n, cv.second);
  }
  Mapping& m = mapping_;
  m.shadow_not_created += t.m.shadow_not_created;
  m.shadow_started_in_neighbour += t.m.shadow_started_in_neighbour;
  m.shadow_ended_at_once += t.m.shadow_ended_at_once;
  m.continuation_started_in_neighbour += t.m.continuation_started_in_neighbour;
  m.continuation_escaped_at_once += t.m.continuation_escaped_at_once;
  m.non_face_routed += t.m.non_face_routed;
  m.non_face_unrouted += t.m.non_face_unrouted;
  m.path_rays_traced += t.m.path_rays_traced;
  m.shadow_rays_traced += t.m.shadow_rays_traced;
}

const std::vector<std::uint64_t>& ProfileRecorder::totals(RayStage stage, std::uint32_t block) const {
  return totals_[static_cast<int>(stage)].at(block);
}

ProfileRecorder::Mapping ProfileRecorder::mapping() const {
  std::lock_guard<std::mutex> lock(mu_);
  return mapping_;
}

namespace {
std::string pairs(const std::vector<std::uint32_t>& ids, const std::vector<std::uint64_t>& v, std::size_t from) {
  std::string s = "[";
  bool first = true;
  for (std::size_t i = from; i < v.size(); ++i) {
    if (!v[i]) continue;
    s += (first ? "[" : ",[") + std::to_string(ids[i - from]) + "," + std::to_string(v[i]) + "]";
    first = false;
  }
  return s + "]";
}
}  // namespace

std::string ProfileRecorder::statistics_json(const std::string& extra) const {
  std::lock_guard<std::mutex> lock(mu_);
  std::ostringstream o;
  const std::size_t nb = nbr_.size();
  o << "{\n  \"format\": \"rayline-render-statistics\",\n  \"version\": 1,\n";
  if (!extra.empty()) o << "  " << extra << ",\n";
  o << "  \"cells\": " << nb << ",\n";
  o << "  \"image\": {\"width\": " << opt_.width << ", \"height\": " << opt_.height << ", \"spp\": " << opt_.spp
    << ", \"tiles\": [" << opt_.tiles_x << ", " << opt_.tiles_y << "]},\n";
  o << "  \"max_depth\": " << opt_.max_depth << ",\n  \"keyframe\": " << opt_.keyframe << ",\n";
  std::vector<std::uint32_t> all(nb);
  for (std::size_t b = 0; b < nb; ++b) all[b] = static_cast<std::uint32_t>(b);
  o << "  \"camera\": {\"rays\": " << camera_total_ << ", \"background\": " << entry_[0]
    << ", \"entry\": " << pairs(all, entry_, 1) << "},\n";
  const Mapping& m = mapping_;
  o << "  \"mapping\": {\"path_rays_traced\": " << m.path_rays_traced << ", \"shadow_rays_traced\": " << m.shadow_rays_traced
    << ", \"shadow_not_created\": " << m.shadow_not_created << ", \"shadow_started_in_neighbour\": "
    << m.shadow_started_in_neighbour << ", \"shadow_ended_at_once\": " << m.shadow_ended_at_once
    << ", \"continuation_started_in_neighbour\": " << m.continuation_started_in_neighbour
    << ", \"continuation_escaped_at_once\": " << m.continuation_escaped_at_once
    << ", \"non_face_routed\": " << m.non_face_routed << ", \"non_face_unrouted\": " << m.non_face_unrouted << "},\n";
  o << "  \"blocks\": [\n";
  for (std::size_t b = 0; b < nb; ++b) {
    const auto& in = totals_[static_cast<int>(RayStage::Intersect)][b];
    const auto& sh = totals_[static_cast<int>(RayStage::Shade)][b];
    const auto& sd = totals_[static_cast<int>(RayStage::Shadow)][b];
    std::uint64_t rays = 0, srays = 0;
    for (auto x : in) rays += x;
    for (auto x : sd) srays += x;
    o << "    {\"id\": " << b << ", \"path_rays\": " << rays << ", \"hits\": " << in[kHit] << ", \"escaped\": " << in[kEscape]
      << ", \"transitions\": " << pairs(nbr_[b], in, kFirstNeighbour) << ", \"terminated\": " << sh[kTerminate]
      << ", \"survived\": " << sh[kSurvive] << ", \"shadow_rays\": " << srays << ", \"occluded\": " << sd[kOccluded]
      << ", \"lit\": " << sd[kLit] << ", \"shadow_transitions\": " << pairs(nbr_[b], sd, kFirstNeighbour) << "}"
      << (b + 1 < nb ? ",\n" : "\n");
  }
  o << "  ]\n}\n";
  return o.str();
}

SceneProfile ProfileRecorder::to_profile(const std::vector<Bytes>& bytes) const {
  std::lock_guard<std::mutex> lock(mu_);
  const std::size_t nb = nbr_.size();
  SceneProfile p;
  p.name = "recorded";
  p.provenance = "ProfileRecorder::to_profile (renderer kernels, no prior)";
  p.width = opt_.width, p.height = opt_.height, p.spp = opt_.spp;
  p.tiles_x = opt_.tiles_x, p.tiles_y = opt_.tiles_y;
  p.max_bounces = opt_.max_depth;
  p.wave_rays = std::max<std::uint64_t>(1, std::uint64_t(opt_.width) * std::uint64_t(opt_.height) / 4);
  p.inflight_rays = std::uint64_t(opt_.width) * std::uint64_t(opt_.height) * std::uint64_t(opt_.spp);
  // Scene means (the analytic section and the value of blocks nothing reached).
  std::uint64_t rays = 0, hits = 0, surv = 0, srays = 0, occ = 0, sexit = 0;
  auto sum = [](const std::vector<std::uint64_t>& v, std::size_t from) {
    std::uint64_t s = 0;
    for (std::size_t i = from; i < v.size(); ++i) s += v[i];
    return s;
  };
  for (std::size_t b = 0; b < nb; ++b) {
    const auto& in = totals_[1][b];
    const auto& sd = totals_[3][b];
    rays += sum(in, 0), hits += in[kHit], surv += totals_[2][b][kSurvive];
    srays += sum(sd, 0), occ += sd[kOccluded], sexit += sum(sd, kFirstNeighbour);
  }
  auto ratio = [](std::uint64_t a, std::uint64_t n, double dflt) { return n ? double(a) / double(n) : dflt; };
  p.analytic.alpha = ratio(hits, rays, 0.5);
  p.analytic.beta = ratio(surv, hits, 0.5);
  p.analytic.shadow_occlusion = ratio(occ, srays, 0.5);
  p.analytic.shadow_exit = ratio(sexit, srays - occ, 0.5);
  const auto& root = index_.bounds;
  for (std::size_t b = 0; b < nb; ++b) {
    const partition::BlockInfo& info = index_.blocks[b];
    ProfileBlock blk;
    blk.bytes = bytes.at(b);
    for (int a = 0; a < 3; ++a) blk.lo[a] = info.cell.lo[a], blk.hi[a] = info.cell.hi[a];
    for (int a = 0; a < 3; ++a) {
      const double face = double(info.cell.hi[(a + 1) % 3] - info.cell.lo[(a + 1) % 3]) *
                          double(info.cell.hi[(a + 2) % 3] - info.cell.lo[(a + 2) % 3]);
      blk.boundary_area += face * ((info.cell.lo[a] <= root.lo[a]) + (info.cell.hi[a] >= root.hi[a]));
    }
    const auto& in = totals_[1][b];
    const auto& sd = totals_[3][b];
    const std::uint64_t n = sum(in, 0), miss = n - in[kHit], trans = sum(in, kFirstNeighbour);
    const std::uint64_t sn = sum(sd, 0), strans = sum(sd, kFirstNeighbour);
    blk.alpha = ratio(in[kHit], n, p.analytic.alpha);
    blk.beta = ratio(totals_[2][b][kSurvive], in[kHit], p.analytic.beta);
    blk.escape = nbr_[b].empty() ? 1.0 : ratio(in[kEscape], miss, 0.5);
    blk.shadow_occlusion = ratio(sd[kOccluded], sn, p.analytic.shadow_occlusion);
    blk.shadow_exit = ratio(strans, sn - sd[kOccluded], p.analytic.shadow_exit);
    double area = 0;
    for (const auto& nb_ : info.neighbours) area += nb_.area;
    for (std::size_t i = 0; i < nbr_[b].size(); ++i) {
      ProfileNeighbour pn;
      pn.block = static_cast<int>(nbr_[b][i]);
      for (const auto& x : info.neighbours)
        if (x.block == nbr_[b][i]) pn.area = x.area;
      pn.p = trans ? double(in[kFirstNeighbour + i]) / double(trans)
                   : (area > 0 ? pn.area / area : 1.0 / double(nbr_[b].size()));
      blk.neighbours.push_back(pn);
    }
    p.blocks.push_back(std::move(blk));
  }
  CameraKey key;
  key.background = ratio(entry_[0], camera_total_, 1.0);
  for (std::size_t b = 0; b < nb; ++b)
    if (entry_[1 + b]) key.entry.emplace_back(static_cast<int>(b), double(entry_[1 + b]) / double(camera_total_));
  // The keyframe index of the recording: keyframes before it are copies (unused by client 0).
  p.camera_path.assign(static_cast<std::size_t>(opt_.keyframe) + 1, key);
  return p;
}

}  // namespace rayline::engine
