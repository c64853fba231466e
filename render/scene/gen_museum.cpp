// museum-like: the character of SponzaMuseum (HPG 2017, Sec. 6) — an architectural
// interior (two-storey arcaded atrium, a roof with an opening the light comes through)
// holding dense, scan-like statues on pedestals. About 15 % of the triangles go to the
// architecture, the rest to up to 63 statues (displaced subdivided spheres).
//
// Layout (metres, y up): court x ∈ [-12, 12], z ∈ [-8, 8]; galleries 4 m deep around it;
// storeys of 6 m; roof at y = 12 with a 12 × 6 m opening over the court.
// Material slots: 0 stone, 1 floor, 2 marble (statues), 3 pedestal.
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "render/scene/assets.hpp"
#include "render/scene/builder.hpp"
#include "render/scene/generators.hpp"
#include "render/scene/rng.hpp"
#include "common/error.hpp"

namespace rayline::scene {
namespace {

constexpr float kStorey = 6.0f;
enum Slot : std::uint16_t { kStone = 0, kFloor = 1, kMarble = 2, kPedestal = 3 };

Affine box_xf(Float3 lo, Float3 hi) {
  return Affine::translate((lo + hi) * 0.5f) * Affine::scale((hi - lo) * 0.5f);
}

// Column and arch positions along the court's edge: (centre, outward normal) pairs.
std::vector<std::pair<Float3, Float3>> column_sites() {
  std::vector<std::pair<Float3, Float3>> s;
  for (int i = 0; i <= 6; ++i) {
    const float x = -12.0f + 4.0f * float(i);
    s.push_back({{x, 0, -8}, {0, 0, -1}});
    s.push_back({{x, 0, 8}, {0, 0, 1}});
  }
  for (int j = 1; j <= 3; ++j) {
    const float z = -8.0f + 4.0f * float(j);
    s.push_back({{-12, 0, z}, {-1, 0, 0}});
    s.push_back({{12, 0, z}, {1, 0, 0}});
  }
  return s;
}

// The building at density q ≥ 1 (segment counts grow linearly with q).
void emit_architecture(MeshSink& sink, int q) {
  MeshBuilder mb;
  const int slab = 2 * q;
  // Ground slab, outer walls, gallery floor (first storey), roof around the opening.
  mb.box(box_xf({-16.4f, -0.3f, -12.4f}, {16.4f, 0, 12.4f}), slab);
  mb.flush(sink, kFloor);
  mb.box(box_xf({-16.4f, 0, -12.4f}, {16.4f, 12.4f, -12.0f}), slab);
  mb.box(box_xf({-16.4f, 0, 12.0f}, {16.4f, 12.4f, 12.4f}), slab);
  mb.box(box_xf({-16.4f, 0, -12.0f}, {-16.0f, 12.4f, 12.0f}), slab);
  mb.box(box_xf({16.0f, 0, -12.0f}, {16.4f, 12.4f, 12.0f}), slab);
  const float fy = kStorey - 0.3f;
  mb.box(box_xf({-16, fy, -12}, {16, kStorey, -8.6f}), slab);
  mb.box(box_xf({-16, fy, 8.6f}, {16, kStorey, 12}), slab);
  mb.box(box_xf({-16, fy, -8.6f}, {-12.6f, kStorey, 8.6f}), slab);
  mb.box(box_xf({12.6f, fy, -8.6f}, {16, kStorey, 8.6f}), slab);
  const float ry = 2 * kStorey;
  mb.box(box_xf({-16, ry, -12}, {16, ry + 0.4f, -3}), slab);
  mb.box(box_xf({-16, ry, 3}, {16, ry + 0.4f, 12}), slab);
  mb.box(box_xf({-16, ry, -3}, {-6, ry + 0.4f, 3}), slab);
  mb.box(box_xf({6, ry, -3}, {16, ry + 0.4f, 3}), slab);
  // Balustrade of the upper gallery.
  mb.box(box_xf({-12.6f, kStorey, -8.75f}, {12.6f, kStorey + 1.0f, -8.6f}), slab);
  mb.box(box_xf({-12.6f, kStorey, 8.6f}, {12.6f, kStorey + 1.0f, 8.75f}), slab);
  mb.box(box_xf({-12.75f, kStorey, -8.6f}, {-12.6f, kStorey + 1.0f, 8.6f}), slab);
  mb.box(box_xf({12.6f, kStorey, -8.6f}, {12.75f, kStorey + 1.0f, 8.6f}), slab);
  mb.flush(sink, kStone);

  // Columns (plinth, shaft with entasis, capital) and the arches between neighbours.
  const int radial = 8 * q, rows = 4 * q;
  std::vector<std::pair<float, float>> profile;
  for (int k = 0; k <= rows; ++k) {
    const float t = float(k) / float(rows);
    profile.push_back({0.35f * (1.0f - 0.12f * t * t) + 0.015f * std::sin(t * 3.14159f), 0.3f + 3.3f * t});
  }
  const auto sites = column_sites();
  for (int storey = 0; storey < 2; ++storey) {
    const float y0 = kStorey * float(storey);
    for (auto [c, n] : sites) {
      (void)n;
      mb.box(box_xf({c.x - 0.45f, y0, c.z - 0.45f}, {c.x + 0.45f, y0 + 0.3f, c.z + 0.45f}), q);
      mb.revolve(profile, radial, Affine::translate({c.x, y0, c.z}));
      mb.box(box_xf({c.x - 0.45f, y0 + 3.6f, c.z - 0.45f}, {c.x + 0.45f, y0 + 3.9f, c.z + 0.45f}), q);
    }
    mb.flush(sink, kStone);
    // Arches: along x on the z = ±8 sides, along z on the x = ±12 sides.
    for (int side = 0; side < 4; ++side)
      for (int i = 0; i < (side < 2 ? 6 : 4); ++i) {
        Affine xf;
        if (side < 2) {
          const float z = side == 0 ? -8.3f : 7.7f;
          xf = Affine::translate({-10.0f + 4.0f * float(i), y0 + 3.9f, z});
        } else {
          const float x = side == 2 ? -11.7f : 12.3f;
          xf = Affine::translate({x, y0 + 3.9f, -6.0f + 4.0f * float(i)}) * Affine::rotate({0, 1, 0}, 90);
        }
        mb.arch(1.55f, 1.75f, 0.6f, 8 * q, xf);
      }
    mb.flush(sink, kStone);
  }
}

std::uint64_t count_architecture(int q) {
  CountingSink c;
  emit_architecture(c, q);
  return c.triangles;
}

// Statue and pedestal sites: 15 in the court, 24 per gallery storey.
std::vector<Float3> statue_sites() {
  std::vector<Float3> s;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 3; ++j) s.push_back({-8.0f + 4.0f * float(i), 0, -4.0f + 4.0f * float(j)});
  for (int storey = 0; storey < 2; ++storey) {
    const float y = kStorey * float(storey);
    for (int j = 0; j < 5; ++j) s.push_back({-14, y, -8.0f + 4.0f * float(j)}), s.push_back({14, y, -8.0f + 4.0f * float(j)});
    for (int i = 0; i < 7; ++i) s.push_back({-12.0f + 4.0f * float(i), y, -10}), s.push_back({-12.0f + 4.0f * float(i), y, 10});
  }
  return s;
}

// A scan statue: each base triangle of `m` midpoint-subdivided `level` times (4^level
// triangles; shared-edge midpoints are computed symmetrically, so no cracks), every
// vertex displaced along its interpolated normal by the noise, then posed by `xf`.
struct ScanEmitter {
  const AssetMesh& m;
  Affine xf;
  std::uint64_t nseed;
  float amp;
  MeshBuilder mb;
  MeshSink& sink;
  std::uint64_t emitted = 0;

  struct V {
    Float3 p, n;
  };
  static V mid(const V& a, const V& b) {
    const Float3 n = a.n + b.n;
    const float l = length(n);
    return {(a.p + b.p) * 0.5f, l > 0 ? n * (1.0f / l) : a.n};
  }
  std::uint32_t out(const V& v) {
    const float d = amp * (fbm(v.p * 9.0f, 3, nseed) + 0.4f * fbm(v.p * 31.0f, 2, nseed + 5));
    return mb.vertex(xf.point(v.p + v.n * d));
  }
  void rec(const V& a, const V& b, const V& c, int level) {
    if (level == 0) {
      mb.tri(out(a), out(b), out(c));
      return;
    }
    const V ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
    rec(a, ab, ca, level - 1), rec(ab, b, bc, level - 1), rec(ca, bc, c, level - 1), rec(ab, bc, ca, level - 1);
  }
  void run(int level) {
    for (const Tri& t : m.triangles) {
      rec({m.positions[t[0]], m.normals[t[0]]}, {m.positions[t[1]], m.normals[t[1]]},
          {m.positions[t[2]], m.normals[t[2]]}, level);
      if (mb.triangle_count() >= (1u << 16)) emitted += mb.triangle_count(), mb.flush(sink, kMarble);
    }
    emitted += mb.triangle_count();
    mb.flush(sink, kMarble);
  }
};

}  // namespace

void emit_museum(std::uint64_t triangles, std::uint64_t seed, MeshSink& out) {
  BudgetSink sink(out);
  Rng rng(seed);
  // Architecture: largest q whose count stays within 15 % of the budget (counts are a
  // quadratic in q: fit it from q = 1, 2, 3).
  // (At q = 1 it is 7 056 triangles: the generator's minimum of 10 000 leaves room for the
  // floor's reserve and one statue.)
  const int q = quadratic_detail_level(count_architecture, 0.15, triangles);
  emit_architecture(sink, q);
  if (sink.emitted + 2000 > triangles)
    throw InputError("--triangles", "", "museum-like needs at least " + std::to_string(sink.emitted + 2000) +
                                            " triangles (its architecture alone is " + std::to_string(sink.emitted) + ")");

  // Statues: as many sites as the budget affords ~20 K triangles each (or, with real
  // scans, the smallest scan), in a seeded order.
  auto sites = statue_sites();
  for (std::size_t i = sites.size(); i > 1; --i) std::swap(sites[i - 1], sites[std::size_t(rng.below(int(i)))]);
  const std::uint64_t left = triangles > sink.emitted + 2000 ? triangles - sink.emitted - 2000 : 0;
  // Real scans (assets/bunny.obj, dragon.ply) when present and the budget affords one per
  // statue; their choice and pose use their own stream so the procedural output is
  // unchanged without assets.
  const auto scans = scan_assets();
  AssetReport& report = last_asset_report();
  report = {"museum-like", 0, 0, {}};
  for (const auto& sc : scans) report.files.push_back(sc->name);
  std::uint64_t smallest = 0;
  for (const auto& sc : scans)
    if (smallest == 0 || sc->triangles.size() < smallest) smallest = sc->triangles.size();
  const bool use_scans = smallest > 0 && left >= smallest + 12;
  const std::uint64_t unit = use_scans ? std::max<std::uint64_t>(20000, smallest + 12) : 20000;
  const std::size_t n = std::clamp<std::size_t>(std::size_t(left / unit), 1, sites.size());
  const std::uint64_t per = left / n > 12 ? left / n - 12 : 0;  // minus the pedestal
  Rng arng(seed ^ 0x5CA9'5CA9'0000'0001ull);
  std::uint64_t carry = 0;  // budget a scan statue left unused, offered to the next
  MeshBuilder mb;
  for (std::size_t i = 0; i < n && per >= 12; ++i) {
    const Float3 p = sites[i];
    mb.box(box_xf({p.x - 0.4f, p.y, p.z - 0.4f}, {p.x + 0.4f, p.y + 1.0f, p.z + 0.4f}), 1);
    mb.flush(sink, kPedestal);
    // A scan-like figure: an elongated blob with a head, lumpy at several scales.
    const std::uint64_t nseed = rng.next();
    const float turn = rng.uniform(0, 360), lean = rng.uniform(-8, 8);
    const float w = rng.uniform(0.32f, 0.42f), h = rng.uniform(0.75f, 0.95f);
    if (use_scans) {
      // The scans that fit this statue's budget; seeded choice; deepest subdivision
      // level that still fits.
      const std::uint64_t budget = per + carry;
      std::vector<const AssetMesh*> fit;
      for (const auto& sc : scans)
        if (sc->triangles.size() <= budget) fit.push_back(sc.get());
      if (!fit.empty()) {
        const AssetMesh& m = *fit[std::size_t(arng.below(int(fit.size())))];
        int level = 0;
        while (level < 8 && (std::uint64_t(m.triangles.size()) << (2 * (level + 1))) <= budget) ++level;
        const float size = arng.uniform(1.3f, 1.7f), spin = arng.uniform(0, 360);
        const Affine xf = Affine::translate({p.x, p.y + 1.0f, p.z}) * Affine::rotate({0, 1, 0}, spin) *
                          Affine::scale({size, size, size});
        ScanEmitter e{m, xf, nseed, 0.004f, {}, sink};
        e.run(level);
        carry = budget - e.emitted;
        ++report.asset_items;
        continue;
      }
    }
    const Affine xf = Affine::translate({p.x, p.y + 1.0f + h, p.z}) * Affine::rotate({0, 1, 0}, turn) *
                      Affine::rotate({1, 0, 0}, lean) * Affine::scale({w, h, w * 0.85f});
    emit_cube_sphere(sink, per, kMarble, [&](Float3 d) {
      float r = 1.0f + 0.22f * fbm(d * 2.2f, 4, nseed) + 0.05f * fbm(d * 11.0f, 3, nseed + 17);
      r += 0.35f * std::max(0.0f, d.y - 0.75f) / 0.25f;  // head
      return xf.point(d * r);
    });
    ++report.procedural_items;
  }
  // The rest of the budget: the court's tiled floor (exact count).
  mb.exact_patch(triangles - sink.emitted, {-12, 0.002f, -8}, {0, 0, 16}, {24, 0, 0});
  mb.flush(sink, kFloor);
}

void describe_museum(Scene& s, const Bounds&) {
  const AssetReport& r = last_asset_report();
  s.description = "museum-like: two-storey arcaded atrium; statues: " +
                  (r.generator == "museum-like" ? r.summary() : std::string("not generated yet"));
  s.materials = {{"stone", {0.75f, 0.72f, 0.65f}, {}},
                 {"floor", {0.55f, 0.5f, 0.45f}, {}},
                 {"marble", {0.85f, 0.85f, 0.82f}, {}},
                 {"pedestal", {0.4f, 0.4f, 0.42f}, {}}};
  // Skylight: a panel just above the roof opening, facing down; and the sky.
  s.area_lights = {{"skylight", {-6, 13.0f, -3}, {12, 0, 0}, {0, 0, 6}, {8, 8, 7.5f}}};
  s.environment.radiance = {0.55f, 0.65f, 0.85f};
  Camera c;
  c.name = "gallery", c.position = {-2, 1.7f, 10.5f}, c.look_at = {1, 3.0f, -6}, c.fov_y_deg = 60;
  c.width = 1024, c.height = 1024;
  Camera up = c;
  up.name = "upper", up.position = {14, 7.7f, 10.5f}, up.look_at = {-4, 2.0f, -4};
  s.cameras = {c, up};
  CameraPath walk;
  walk.name = "walk", walk.frames = 120, walk.interpolation = Interpolation::catmull_rom;
  const std::array<Float3, 5> pts = {Float3{-14, 1.7f, 10}, {14, 1.7f, 10}, {14, 1.7f, -10}, {-14, 1.7f, -10},
                                      {-14, 1.7f, 10}};
  for (std::size_t k = 0; k < pts.size(); ++k) {
    CameraKey key{double(k), c};
    key.camera.position = pts[k];
    key.camera.look_at = {0, 2.5f, 0};
    walk.keys.push_back(key);
  }
  s.camera_paths = {walk};
}

}  // namespace rayline::scene
