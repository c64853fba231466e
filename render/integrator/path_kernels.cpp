#include "render/integrator/path_kernels.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "render/integrator/cell_walk.hpp"
#include "render/integrator/sampler.hpp"

namespace rayline::trace {

using scene::cross;
using scene::dot;
using scene::Float3;
using scene::normalize;

namespace {

constexpr float kInvPi = 0.318309886183790671538f;
constexpr float kInf = std::numeric_limits<float>::infinity();

Float3 mul(Float3 a, Float3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
bool is_black(Float3 a) { return a.x <= 0 && a.y <= 0 && a.z <= 0; }
float max_component(Float3 a) { return std::max(a.x, std::max(a.y, a.z)); }

// Orthonormal basis around a unit normal (Duff et al. 2017, branchless).
void basis(Float3 n, Float3& t, Float3& b) {
  const float s = std::copysign(1.0f, n.z);
  const float a = -1.0f / (s + n.z);
  const float c = n.x * n.y * a;
  t = {1.0f + s * n.x * n.x * a, s * c, -s * n.x};
  b = {c, s + n.y * n.y * a, -n.y};
}

// The ray ended without a further cell: path rays escape (environment), shadow rays
// reached their light.
void finish(const TraceSettings& ts, const RayRecord& r, RayCounts& counts) {
  if (r.kind == RayKind::Path) {
    ++counts.escaped;
    ++counts.paths_ended;
    const Float3 env = ts.scene->environment.radiance;
    if (!is_black(env)) ts.film->add(r.pixel, mul(r.weight, env));
  } else {
    ++counts.unoccluded;
    ts.film->add(r.pixel, r.weight);
  }
}

constexpr std::uint8_t kFirstCell = 1;  // RayRecord::flags: the ray's first cell (tnear is its own start)

// Continue `r` after its current cell (texit), or finish it. New rays come with texit = 0.
void advance(const TraceSettings& ts, RayRecord r, std::vector<RayRecord>& out, RayCounts& counts, bool fresh = false) {
  CellSpan span;
  while (r.texit < r.tfar && enter_cell(*ts.cells, r.org, r.dir, r.texit, r.tfar, span)) {
    if (ts.skip_empty) {
      // The cell's query interval (query_interval: widened by delta(t) on both sides).
      const float w0 = ts.overlap_rel * std::fabs(span.tenter) + ts.overlap_abs;
      const float w1 = ts.overlap_rel * std::fabs(span.texit) + ts.overlap_abs;
      if (!segment_may_hit(ts.cells->blocks[span.cell], r.org, r.dir, span.tenter - w0, span.texit + w1)) {
        // As if traced there without a hit: on to the next cell, no longer the first.
        ++counts.skipped;
        r.texit = span.texit;
        fresh = false;
        continue;
      }
    }
    r.flags = fresh ? kFirstCell : std::uint8_t(0);
    r.cell = span.cell;
    r.tnear = span.tenter;
    r.texit = span.texit;
    out.push_back(r);
    return;
  }
  finish(ts, r, counts);
}

// Shading at a hit (Fig. 3's shading/sampling, fused into RayIntersect on the CPU).
void shade(const TraceSettings& ts, const HitTriangle& h, const RayRecord& r, float t, std::vector<RayRecord>& out,
           RayCounts& counts) {
  Float3 n = normalize(cross(h.v1 - h.v0, h.v2 - h.v0));
  if (dot(n, r.dir) > 0) n = n * -1.0f;  // two-sided: face the incoming ray
  const Float3 p = r.org + r.dir * t;
  const scene::Material& m = ts.scene->materials[h.material];
  if (!is_black(m.emission)) ts.film->add(r.pixel, mul(r.weight, m.emission));
  const std::uint32_t hit = r.bounce + 1u;  // 1-based surface hit count
  const Float3 f = m.albedo * kInvPi;       // Lambertian BRDF
  const Float3 o = offset_ray_origin(p, n);
  const SeedKey seed(ts.seed);

  // Next-event estimation towards one area light.
  const auto& lights = ts.scene->area_lights;
  if (!lights.empty() && !is_black(m.albedo)) {
    const KeyedRng pick(seed, r.pixel, r.sample, hit, Purpose::LightPick);
    const auto li = std::min<std::size_t>(std::size_t(pick.uniform(0) * float(lights.size())), lights.size() - 1);
    const scene::AreaLight& L = lights[li];
    const KeyedRng pt(seed, r.pixel, r.sample, hit, Purpose::LightPoint);
    const Float3 q = L.corner + L.edge_u * pt.uniform(0) + L.edge_v * pt.uniform(1);
    const Float3 ln = cross(L.edge_u, L.edge_v);
    const float area = scene::length(ln);
    const Float3 w = q - p;
    const float d2 = dot(w, w);
    if (area > 0 && d2 > 0) {
      const Float3 wi = w * (1.0f / std::sqrt(d2));
      const float cos_s = dot(n, wi), cos_l = -dot(ln, wi) / area;
      if (cos_s > 0 && cos_l > 0) {
        const float g = cos_s * cos_l * area * float(lights.size()) / d2;  // 1 / pdf folded in
        const Float3 c = mul(mul(r.weight, f), L.emission) * g;
        if (!is_black(c)) {
          RayRecord s;
          const Float3 ws = q - o;
          const float dist = scene::length(ws);
          s.org = o;
          s.dir = ws * (1.0f / dist);
          s.tfar = dist;
          s.texit = 0;
          s.weight = c;
          s.pixel = r.pixel, s.sample = r.sample, s.bounce = static_cast<std::uint16_t>(hit);
          s.kind = RayKind::Shadow;
          ++counts.created;
          advance(ts, s, out, counts, true);
        }
      }
    }
  }

  // Continuation: cosine-weighted hemisphere; f·cos/pdf = albedo.
  if (int(hit) >= ts.max_depth) {
    ++counts.terminated;
    ++counts.paths_ended;
    return;
  }
  Float3 weight = mul(r.weight, m.albedo);
  if (hit >= 3) {
    const float q = std::min(0.95f, max_component(weight));
    const KeyedRng rr(seed, r.pixel, r.sample, hit, Purpose::Roulette);
    if (!(rr.uniform(0) < q)) {
      ++counts.terminated;
      ++counts.paths_ended;
      return;
    }
    weight = weight * (1.0f / q);
  }
  if (is_black(weight)) {
    ++counts.terminated;
    ++counts.paths_ended;
    return;
  }
  const KeyedRng bs(seed, r.pixel, r.sample, hit, Purpose::Bounce);
  const float u1 = bs.uniform(0), u2 = bs.uniform(1);
  const float rad = std::sqrt(u1), phi = 6.28318530717958647692f * u2;
  Float3 tx, ty;
  basis(n, tx, ty);
  const Float3 d = normalize(tx * (rad * std::cos(phi)) + ty * (rad * std::sin(phi)) + n * std::sqrt(std::max(0.0f, 1 - u1)));
  RayRecord c;
  c.org = o;
  c.dir = d;
  c.tfar = kInf;
  c.texit = 0;
  c.weight = weight;
  c.pixel = r.pixel, c.sample = r.sample, c.bounce = static_cast<std::uint16_t>(hit);
  c.kind = RayKind::Path;
  ++counts.terminated;  // this ray ends here; its continuation is a new ray
  ++counts.created;
  advance(ts, c, out, counts, true);
}

}  // namespace

void query_interval(const TraceSettings& ts, const RayRecord& r, float& tmin, float& tmax) {
  tmin = (r.flags & kFirstCell) ? r.tnear : std::max(0.0f, r.tnear - (ts.overlap_rel * r.tnear + ts.overlap_abs));
  tmax = std::min(r.texit + (ts.overlap_rel * r.texit + ts.overlap_abs), r.tfar);
}

float canonical_hit_distance(const RayRecord& r, const HitTriangle& h, float engine_t) {
  // Moller & Trumbore 1997, t only, in double: e1 = v1 - v0, e2 = v2 - v0,
  // t = (e2 . ((o - v0) x e1)) / (e1 . (d x e2)).
  const double e1[3] = {double(h.v1.x) - h.v0.x, double(h.v1.y) - h.v0.y, double(h.v1.z) - h.v0.z};
  const double e2[3] = {double(h.v2.x) - h.v0.x, double(h.v2.y) - h.v0.y, double(h.v2.z) - h.v0.z};
  const double d[3] = {r.dir.x, r.dir.y, r.dir.z};
  const double s[3] = {double(r.org.x) - h.v0.x, double(r.org.y) - h.v0.y, double(r.org.z) - h.v0.z};
  const double p[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
  const double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
  const double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
  const double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
  // A hit the engine found is never parallel in practice; keep its t if it were.
  if (!(std::fabs(det) > 0) || !std::isfinite(t)) return engine_t;
  return static_cast<float>(t);
}

void after_closest_hit(const TraceSettings& ts, const RayRecord& r, const HitTriangle* hit, float engine_t,
                       std::vector<RayRecord>& out, RayCounts& counts) {
  ++counts.traced;
  if (hit) shade(ts, *hit, r, canonical_hit_distance(r, *hit, engine_t), out, counts);
  else advance(ts, r, out, counts);
}

void after_occlusion_test(const TraceSettings& ts, const RayRecord& r, bool occluded, std::vector<RayRecord>& out,
                          RayCounts& counts) {
  ++counts.traced;
  if (occluded) ++counts.occluded;
  else advance(ts, r, out, counts);
}

void TraceSettings::set_bounds(const scene::Bounds& b) {
  const Float3 e = b.extent();
  overlap_abs = 1e-7f * std::max({e.x, e.y, e.z, 1e-30f});
}

Float3 offset_ray_origin(Float3 p, Float3 n) {
  constexpr float kOrigin = 1.0f / 32.0f, kFloatScale = 1.0f / 65536.0f, kIntScale = 256.0f;
  Float3 out;
  for (int a = 0; a < 3; ++a) {
    const auto of = static_cast<std::int32_t>(kIntScale * n[a]);
    const auto bits = std::bit_cast<std::int32_t>(p[a]);
    const float pi = std::bit_cast<float>(bits + (p[a] < 0 ? -of : of));
    out[a] = std::fabs(p[a]) < kOrigin ? p[a] + kFloatScale * n[a] : pi;
  }
  return out;
}

void place_new_ray(const TraceSettings& ts, RayRecord r, std::vector<RayRecord>& out, RayCounts& counts) {
  ++counts.created;
  advance(ts, r, out, counts, true);
}

void generate_camera_ray(const TraceSettings& ts, Float3 origin, Float3 dir, std::uint32_t pixel, std::uint32_t sample,
                         std::vector<RayRecord>& out, RayCounts& counts) {
  ts.film->count_sample(pixel);
  RayRecord r;
  r.org = origin;
  r.dir = dir;
  r.tfar = kInf;
  r.texit = 0;
  r.weight = {1, 1, 1};
  r.pixel = pixel;
  r.sample = sample;
  r.bounce = 0;
  r.kind = RayKind::Path;
  place_new_ray(ts, r, out, counts);
}

}  // namespace rayline::trace
