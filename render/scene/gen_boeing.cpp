// boeing-like: the character of the Boeing 777 model (HPG 2017, Sec. 6) — a closed
// fuselage hull packed with thousands of posed CAD parts (pipes, ducts, cables,
// brackets, boxes, frames), most of them hidden from outside.
//
// Layout (metres, y up, fuselage along +x from 0 to 64, radius 3.1): nose ogive,
// cylindrical body, upswept tapering tail closed by a pole; wings and stabilisers as
// closed slabs. About 8 % of the triangles go to the hull and wings, the rest to parts.
// Material slots: 0 hull, 1 structure, 2 pipes, 3 brackets, 4 cables, 5 boxes, 6 floor.
#include <algorithm>
#include <cmath>
#include <vector>

#include "render/scene/assets.hpp"
#include "render/scene/builder.hpp"
#include "render/scene/generators.hpp"
#include "render/scene/rng.hpp"

namespace rayline::scene {
namespace {

constexpr float kLength = 64.0f, kRadius = 3.1f;
enum Slot : std::uint16_t { kHull = 0, kStructure = 1, kPipe = 2, kBracket = 3, kCable = 4, kBox = 5, kFloor = 6 };

// Fuselage radius at x (0 at both ends).
float hull_radius(float x) {
  if (x <= 8) {
    const float t = 1 - x / 8;
    return kRadius * std::sqrt(std::max(0.0f, 1 - t * t));
  }
  if (x >= 46) {
    const float t = std::min(1.0f, (x - 46) / 18);
    return kRadius * std::max(0.0f, 1 - 0.8f * std::pow(t, 1.4f)) * (t >= 1 ? 0.0f : 1.0f);
  }
  return kRadius;
}

Affine box_xf(Float3 c, Float3 half, const Affine& pose = {}) {
  return pose * Affine::translate(c) * Affine::scale(half);
}

// Hull (surface of revolution about x) and wings, at density q.
void emit_hull(MeshSink& sink, int q) {
  MeshBuilder mb;
  std::vector<std::pair<float, float>> profile;
  const int rows = 24 * q;
  for (int k = 0; k <= rows; ++k) {
    // Denser near the ends where the profile curves.
    const float u = float(k) / float(rows);
    const float x = kLength * (u - 0.9f * std::sin(2 * 3.14159265f * u) / (2 * 3.14159265f));
    profile.push_back({k == 0 || k == rows ? 0.0f : std::max(0.02f, hull_radius(std::clamp(x, 0.0f, kLength))), x});
  }
  // revolve() turns about local y; map local y → world x.
  mb.revolve(profile, 16 * q, Affine::rotate({0, 0, 1}, -90));
  mb.flush(sink, kHull);
  const int n = 2 * q;
  for (float side : {-1.0f, 1.0f}) {
    mb.box(box_xf({27, -1.6f, side * 10.5f}, {3.5f, 0.25f, 8.0f}, Affine::rotate({0, 1, 0}, side * 8)), n);
    mb.box(box_xf({59, 0.8f, side * 4.0f}, {1.6f, 0.12f, 3.0f}), n);
  }
  mb.box(box_xf({60, 3.8f, 0}, {1.8f, 3.0f, 0.15f}), n);
  mb.flush(sink, kHull);
}

std::uint64_t count_hull(int q) {
  CountingSink c;
  emit_hull(c, q);
  return c.triangles;
}

// A random point inside the usable cabin/cargo volume.
Float3 inside_point(Rng& rng, float margin) {
  const float x = rng.uniform(6, 56);
  const float r = hull_radius(x) * margin * std::sqrt(rng.uniform());
  const float a = rng.uniform(0, 6.2831853f);
  return {x, r * std::sin(a), r * std::cos(a)};
}

Float3 clamp_inside(Float3 p, float margin) {
  const float x = std::clamp(p.x, 4.0f, 58.0f);
  const float rmax = hull_radius(x) * margin;
  const float r = std::sqrt(p.y * p.y + p.z * p.z);
  if (r > rmax && r > 0) p.y *= rmax / r, p.z *= rmax / r;
  p.x = x;
  return p;
}

// One posed part of about `detail` triangles into mb; returns its material slot.
std::uint16_t make_part(MeshBuilder& mb, Rng& rng, int detail) {
  const int kind = rng.below(100);
  if (kind < 30) {  // pipe run: straight legs with elbows, mostly along the fuselage
    const int radial = std::clamp(int(std::sqrt(detail / 6.0)), 4, 64);
    const int legs = 2 + rng.below(3);
    std::vector<Float3> path{inside_point(rng, 0.85f)};
    const float radius = rng.uniform(0.015f, 0.07f);
    const int per_leg = std::max(1, detail / (2 * radial * legs) - 2);
    for (int l = 0; l < legs; ++l) {
      Float3 d = l % 2 == 0 ? Float3{rng.uniform(-1, 1) < 0 ? -1.0f : 1.0f, 0, 0} : rng.unit_vector();
      const float len = l % 2 == 0 ? rng.uniform(1.0f, 5.0f) : rng.uniform(0.2f, 0.8f);
      const Float3 end = clamp_inside(path.back() + d * len, 0.9f);
      const Float3 start = path.back();
      for (int s = 1; s <= per_leg; ++s) path.push_back(lerp(start, end, float(s) / float(per_leg)));
    }
    mb.tube(path, radius, radial, true);
    return kPipe;
  }
  if (kind < 50) {  // cable: thin smooth random curve
    const int radial = std::clamp(int(std::sqrt(detail / 10.0)), 3, 24);
    const int samples = std::max(2, detail / (2 * radial));
    Float3 cp[4];
    cp[0] = inside_point(rng, 0.9f);
    for (int k = 1; k < 4; ++k) cp[k] = clamp_inside(cp[k - 1] + Float3{rng.uniform(0.3f, 1.5f), 0, 0} + rng.unit_vector() * 0.5f, 0.93f);
    std::vector<Float3> path;
    for (int s = 0; s < samples; ++s) {
      const float t = float(s) / float(samples - 1);
      const float u = 1 - t;  // cubic Bézier through the four control points
      path.push_back(cp[0] * (u * u * u) + cp[1] * (3 * u * u * t) + cp[2] * (3 * u * t * t) + cp[3] * (t * t * t));
    }
    mb.tube(path, rng.uniform(0.004f, 0.015f), radial, true);
    return kCable;
  }
  const Float3 c = inside_point(rng, 0.8f);
  const Affine pose = Affine::translate(c) * Affine::rotate(rng.unit_vector(), rng.uniform(0, 360));
  if (kind < 75) {  // bracket: L of two plates, a gusset and bolts
    const int n = std::clamp(int(std::sqrt(detail / 60.0)), 1, 40);
    const float s = rng.uniform(0.05f, 0.25f);
    mb.box(box_xf({0, 0, 0}, {s, 0.01f + 0.05f * s, s * 0.6f}, pose), n);
    mb.box(box_xf({-s, s, 0}, {0.01f + 0.05f * s, s, s * 0.6f}, pose), n);
    mb.box(box_xf({-s * 0.5f, s * 0.5f, 0}, {s * 0.5f, 0.01f, s * 0.1f}, pose * Affine::rotate({0, 0, 1}, 45)), n);
    const int radial = std::clamp(n * 4, 6, 48);
    for (float off : {-0.5f, 0.5f}) {
      const Float3 a = pose.point({s * 0.5f, -0.03f, off * s}), b = pose.point({s * 0.5f, 0.03f + 0.1f * s, off * s});
      const Float3 path[2] = {a, b};
      mb.tube(path, 0.008f + 0.02f * s, radial, true);
    }
    return kBracket;
  }
  if (kind < 90) {  // LRU box with a handle
    const int n = std::clamp(int(std::sqrt(detail / 16.0)), 1, 128);
    const Float3 h{rng.uniform(0.1f, 0.35f), rng.uniform(0.08f, 0.25f), rng.uniform(0.1f, 0.4f)};
    mb.box(box_xf({0, 0, 0}, h, pose), n);
    const Float3 path[4] = {pose.point({-h.x * 0.5f, h.y, 0}), pose.point({-h.x * 0.5f, h.y + 0.05f, 0}),
                            pose.point({h.x * 0.5f, h.y + 0.05f, 0}), pose.point({h.x * 0.5f, h.y, 0})};
    mb.tube(path, 0.008f, std::clamp(n, 4, 24), true);
    return kBox;
  }
  // duct: a big straight tube along x
  const int radial = std::clamp(int(std::sqrt(detail / 4.0)), 6, 96);
  const int segs = std::max(1, detail / (2 * radial) - 1);
  const Float3 a = inside_point(rng, 0.75f);
  const Float3 b = clamp_inside(a + Float3{rng.uniform(2, 8), 0, 0}, 0.8f);
  std::vector<Float3> path;
  for (int s = 0; s <= segs; ++s) path.push_back(lerp(a, b, float(s) / float(segs)));
  mb.tube(path, rng.uniform(0.08f, 0.2f), radial, true);
  return kPipe;
}

}  // namespace

void emit_boeing(std::uint64_t triangles, std::uint64_t seed, MeshSink& out) {
  BudgetSink sink(out);
  Rng rng(seed);
  // Hull and wings: the largest q within 8 % of the budget (quadratic in q).
  const int q = quadratic_detail_level(count_hull, 0.08, triangles);
  emit_hull(sink, q);

  // Structure: circumferential frames every 0.6 m and the cabin floor.
  MeshBuilder mb;
  const int detail = int(std::clamp(0.5 * std::sqrt(double(triangles)), 24.0, 20000.0));
  const int ring_radial = std::clamp(int(std::sqrt(detail / 8.0)), 3, 16);
  const int ring_segments = std::clamp(detail / (2 * ring_radial), 8, 2048);
  for (float x = 6.0f; x < 56.0f && sink.emitted + std::uint64_t(2 * ring_radial * ring_segments) < triangles / 4;
       x += 0.6f) {
    const float r = hull_radius(x) * 0.96f;
    std::vector<Float3> loop;
    for (int s = 0; s < ring_segments; ++s) {
      const float t = 6.2831853f * float(s) / float(ring_segments);
      loop.push_back({x, r * std::sin(t), r * std::cos(t)});
    }
    mb.tube(loop, 0.05f, ring_radial, false, true);
    mb.flush(sink, kStructure);
  }
  mb.box(box_xf({31, -0.9f, 0}, {24, 0.05f, 2.6f}), 1);
  mb.flush(sink, kStructure);

  // Parts until the next one might not fit, then the cargo floor takes the rest.
  const std::uint64_t reserve = 2;
  // Real CAD parts (assets/occt/*.stl) when present: about one part in six is a posed
  // copy of a seeded choice among those small enough (≤ max(8·detail, 1 % of the
  // budget)). Own random stream: without assets the output is unchanged.
  const auto cad = cad_assets();
  AssetReport& report = last_asset_report();
  report = {"boeing-like", 0, 0, {}};
  std::vector<const AssetMesh*> small;
  const std::uint64_t cap = std::max<std::uint64_t>(8ull * std::uint64_t(detail), triangles / 100);
  for (const auto& m : cad) {
    report.files.push_back("occt/" + m->name);
    if (m->triangles.size() <= cap) small.push_back(m.get());
  }
  Rng arng(seed ^ 0xCAD0'CAD0'0000'0002ull);
  for (;;) {
    if (!small.empty() && arng.below(6) == 0) {
      const AssetMesh& m = *small[std::size_t(arng.below(int(small.size())))];
      const Float3 c = inside_point(arng, 0.75f);
      const float size = arng.uniform(0.15f, 0.6f);
      const Affine pose = Affine::translate(c) * Affine::rotate(arng.unit_vector(), arng.uniform(0, 360)) *
                          Affine::scale({size, size, size}) * Affine::translate({0, -0.5f, 0});
      for (Float3 v : m.positions) mb.vertex(pose.point(v));
      for (const Tri& t : m.triangles) mb.tri(t[0], t[1], t[2]);
      if (sink.emitted + mb.triangle_count() + reserve > triangles) {
        mb.clear();
        break;
      }
      mb.flush(sink, kBox);
      ++report.asset_items;
      continue;
    }
    const std::uint16_t slot = make_part(mb, rng, detail);
    if (sink.emitted + mb.triangle_count() + reserve > triangles) {
      mb.clear();
      break;
    }
    mb.flush(sink, slot);
  }
  mb.exact_patch(triangles - sink.emitted, {10, -2.2f, -1.4f}, {0, 0, 2.8f}, {40, 0, 0});
  mb.flush(sink, kFloor);
}

void describe_boeing(Scene& s, const Bounds&) {
  const AssetReport& r = last_asset_report();
  s.description = "boeing-like: fuselage packed with procedural pipes, brackets, cables, boxes; CAD parts: " +
                  (r.generator == "boeing-like" ? r.summary() : std::string("not generated yet"));
  s.materials = {{"hull", {0.78f, 0.78f, 0.8f}, {}},     {"structure", {0.5f, 0.5f, 0.52f}, {}},
                 {"pipes", {0.7f, 0.62f, 0.3f}, {}},     {"brackets", {0.35f, 0.35f, 0.38f}, {}},
                 {"cables", {0.1f, 0.1f, 0.12f}, {}},    {"boxes", {0.25f, 0.32f, 0.25f}, {}},
                 {"floor", {0.4f, 0.35f, 0.3f}, {}}};
  // Sun-like panel high above, the sky, and a strip of cabin lights inside the hull.
  s.area_lights = {{"sun", {10, 40, -20}, {40, 0, 0}, {0, 0, 40}, {6, 6, 5.5f}},
                   {"cabin", {8, 2.4f, -0.3f}, {0, 0, 0.6f}, {46, 0, 0}, {3, 3, 2.8f}}};
  s.environment.radiance = {0.5f, 0.6f, 0.8f};
  Camera out;
  out.name = "outside", out.position = {-14, 14, 46}, out.look_at = {32, 0, 0}, out.fov_y_deg = 40;
  Camera cabin = out;
  cabin.name = "cabin", cabin.position = {8, 0.5f, 0}, cabin.look_at = {40, 0, 0}, cabin.fov_y_deg = 70;
  s.cameras = {out, cabin};
  CameraPath fly;
  fly.name = "flyby", fly.frames = 120, fly.interpolation = Interpolation::catmull_rom;
  for (int k = 0; k <= 6; ++k) {
    const float a = 3.14159265f * float(k) / 6.0f;
    CameraKey key{double(k), out};
    key.camera.position = {32 - 60 * std::cos(a), 14, 60 * std::sin(a) + 5};
    fly.keys.push_back(key);
  }
  s.camera_paths = {fly};
}

}  // namespace rayline::scene
