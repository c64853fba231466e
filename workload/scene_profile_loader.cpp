// JSON reader of scene profiles (schema: docs/scene-profiles.md). Every error names the
// file and the field, e.g. `boeing.profile.json: blocks[3].neighbours[1]: unknown block 200`
// (common/json_fields.hpp); one function per section of the format.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "common/error.hpp"
#include "common/input_file.hpp"
#include "common/json_fields.hpp"
#include "workload/scene_profile.hpp"

namespace rayline {

using nlohmann::json;

namespace {

constexpr double kSumTolerance = 1e-6;

double finite_number(const JsonField& v) {
  const double x = v.number();
  if (!std::isfinite(x)) v.fail("must be finite");
  return x;
}

double probability_value(const JsonField& v) {
  const double p = finite_number(v);
  if (p < 0 || p > 1) v.fail("probability " + std::to_string(p) + " outside [0, 1]");
  return p;
}

// A probability member; without `dflt` (>= 0) it is required.
double probability(const JsonField& object, const char* key, double dflt = -1) {
  if (!object.has(key) && dflt >= 0) return dflt;
  return probability_value(object.at(key));
}

// A size or count: an integer > 0 (sizes may not be negative or zero).
std::uint64_t positive(const JsonField& object, const char* key, std::uint64_t dflt) {
  const auto v = object.find(key);
  if (!v) return dflt;
  if (!(v->number() > 0)) v->fail("must be > 0 (got " + v->json().dump() + ")");
  if (!v->json().is_number_integer() && !v->json().is_number_unsigned()) v->fail("expected an integer");
  return v->json().get<std::uint64_t>();
}

// An optional string member ("" when absent).
std::string text(const JsonField& object, const char* key) {
  const auto v = object.find(key);
  return v ? v->string() : std::string();
}

std::array<double, 3> vec3(const JsonField& object, const char* key) {
  const JsonField v = object.at(key);
  if (!v.json().is_array() || v.size() != 3) v.fail("expected [x, y, z]");
  return {finite_number(v.element(0)), finite_number(v.element(1)), finite_number(v.element(2))};
}

// A tuple such as [block, area, p]: an array of `size` elements, the first an integer.
bool is_tuple(const json& v, std::size_t size) { return v.is_array() && v.size() == size && v[0].is_number_integer(); }

void header(const JsonField& root, SceneProfile& p) {
  root.only_keys({"format", "version", "name", "description", "provenance", "image", "batching", "records", "analytic",
                  "block_count", "blocks", "camera_path"});
  if (!root.has("format") || text(root, "format") != "rayline-scene-profile")
    root.fail_at("format", "expected \"rayline-scene-profile\"");
  if (const auto v = root.find("version"); !v || !v->json().is_number_integer() || v->json() != 1)
    root.fail_at("version", "expected 1");
  p.name = text(root, "name");
  p.provenance = text(root, "provenance");
  (void)text(root, "description");
}

void image(const JsonField& f, SceneProfile& p) {
  f.only_keys({"width", "height", "spp", "tiles"});
  p.width = static_cast<int>(positive(f, "width", 512));
  p.height = static_cast<int>(positive(f, "height", 512));
  p.spp = static_cast<int>(positive(f, "spp", 4));
  const auto t = f.find("tiles");
  if (!t) return;
  const json& v = t->json();
  if (!v.is_array() || v.size() != 2 || !v[0].is_number_integer() || !v[1].is_number_integer())
    t->fail("expected [tiles_x, tiles_y]");
  p.tiles_x = v[0].get<int>();
  p.tiles_y = v[1].get<int>();
  if (p.tiles_x < 1 || p.tiles_y < 1 || p.tiles_x > p.width || p.tiles_y > p.height || p.tiles() > 4096)
    t->fail("must be >= 1, fit the image, and number at most 4096");
}

void batching(const JsonField& f, SceneProfile& p) {
  f.only_keys({"wave_rays", "inflight_rays", "max_bounces"});
  p.wave_rays = positive(f, "wave_rays", p.wave_rays);
  p.inflight_rays = positive(f, "inflight_rays", p.inflight_rays);
  p.max_bounces = static_cast<int>(positive(f, "max_bounces", static_cast<std::uint64_t>(p.max_bounces)));
  if (p.max_bounces > 200) f.at("max_bounces").fail("at most 200");
}

void records(const JsonField& f, SceneProfile& p) {
  f.only_keys({"ray_bytes", "shadow_ray_bytes", "hit_bytes", "sample_bytes", "framebuffer_bytes_per_pixel",
               "request_bytes"});
  p.ray_bytes = positive(f, "ray_bytes", p.ray_bytes);
  p.shadow_ray_bytes = positive(f, "shadow_ray_bytes", p.shadow_ray_bytes);
  p.hit_bytes = positive(f, "hit_bytes", p.hit_bytes);
  p.sample_bytes = positive(f, "sample_bytes", p.sample_bytes);
  p.framebuffer_bytes_per_pixel = positive(f, "framebuffer_bytes_per_pixel", p.framebuffer_bytes_per_pixel);
  p.request_bytes = positive(f, "request_bytes", p.request_bytes);
}

void analytic(const JsonField& f, AnalyticParameters& a) {
  f.only_keys({"alpha", "beta", "shadow_occlusion", "shadow_exit"});
  a.alpha = probability(f, "alpha", a.alpha);
  a.beta = probability(f, "beta", a.beta);
  a.shadow_occlusion = probability(f, "shadow_occlusion", a.shadow_occlusion);
  a.shadow_exit = probability(f, "shadow_exit", a.shadow_exit);
}

// The block list, checked against block_count (a truncated file must not load).
std::vector<JsonField> block_list(const JsonField& root) {
  const auto bl = root.find("blocks");
  if (!bl || !bl->json().is_array() || bl->json().empty()) root.fail_at("blocks", "expected a non-empty array");
  const auto bc = root.find("block_count");
  if (!bc || !bc->json().is_number_integer()) root.fail_at("block_count", "expected an integer");
  if (bc->json().get<std::int64_t>() != static_cast<std::int64_t>(bl->size()))
    bc->fail("says " + bc->json().dump() + " but the file lists " + std::to_string(bl->size()) + " blocks");
  return bl->elements();
}

// Face neighbours of block i and their Markov transition probabilities (Sec. 5.2).
void neighbours(const JsonField& f, int i, int nb, ProfileBlock& b) {
  const auto ns = f.find("neighbours");
  if (!ns || !ns->json().is_array()) f.fail_at("neighbours", "expected an array of [block, area, p]");
  double psum = 0;
  std::set<int> seen;
  for (const JsonField& e : ns->elements()) {
    if (!is_tuple(e.json(), 3)) e.fail("expected [block, area, p]");
    ProfileNeighbour n;
    n.block = e.json()[0].get<int>();
    if (n.block < 0 || n.block >= nb) e.fail("unknown block " + std::to_string(n.block));
    if (n.block == i) e.fail("a block is not its own neighbour");
    if (!seen.insert(n.block).second) e.fail("neighbour " + std::to_string(n.block) + " listed twice");
    n.area = finite_number(e.element(1));
    if (n.area < 0) e.element(1).fail("area must be >= 0");
    n.p = finite_number(e.element(2));
    if (n.p < 0 || n.p > 1) e.element(2).fail("probability outside [0, 1]");
    psum += n.p;
    b.neighbours.push_back(n);
  }
  if (!b.neighbours.empty() && std::abs(psum - 1) > kSumTolerance)
    ns->fail("transition probabilities sum to " + std::to_string(psum) + ", not 1");
}

ProfileBlock block(const JsonField& f, int i, int nb) {
  f.only_keys({"id", "bytes", "lo", "hi", "boundary_area", "alpha", "beta", "escape", "shadow_occlusion", "shadow_exit",
               "neighbours", "triangles"});
  if (const auto id = f.find("id"); id && id->json() != i)
    id->fail("must equal the block's position " + std::to_string(i));
  ProfileBlock b;
  if (!f.has("bytes")) f.fail_at("bytes", "missing");
  b.bytes = positive(f, "bytes", 0);
  b.lo = vec3(f, "lo");
  b.hi = vec3(f, "hi");
  for (std::size_t a = 0; a < 3; ++a)
    if (b.hi[a] < b.lo[a]) f.at("hi").fail("below lo");
  b.boundary_area = f.has("boundary_area") ? finite_number(f.at("boundary_area")) : 0.0;
  if (b.boundary_area < 0) f.at("boundary_area").fail("must be >= 0");
  b.alpha = probability(f, "alpha");
  b.beta = probability(f, "beta");
  b.escape = probability(f, "escape");
  b.shadow_occlusion = probability(f, "shadow_occlusion");
  b.shadow_exit = probability(f, "shadow_exit");
  neighbours(f, i, nb, b);
  if (b.neighbours.empty() && b.escape < 1 && b.alpha < 1)
    f.at("escape").fail("a block without neighbours must let every missed ray escape (escape = 1)");
  return b;
}

// Symmetry: a neighbour relation goes both ways.
void check_symmetric(const JsonInput& in, const SceneProfile& p) {
  for (std::size_t i = 0; i < p.blocks.size(); ++i)
    for (const ProfileNeighbour& n : p.blocks[i].neighbours) {
      const auto& back = p.blocks[static_cast<std::size_t>(n.block)].neighbours;
      if (std::none_of(back.begin(), back.end(), [i](const ProfileNeighbour& x) { return x.block == int(i); }))
        in.fail(field_index("blocks", static_cast<std::size_t>(n.block)) + ".neighbours",
                "block " + std::to_string(i) + " lists it as a neighbour but not vice versa");
    }
}

// One camera keyframe: where its primary rays enter the scene.
CameraKey camera_key(const JsonField& f, int nb) {
  f.only_keys({"background", "entry", "description"});
  CameraKey key;
  key.background = probability(f, "background", 0.0);
  double sum = key.background;
  const auto en = f.find("entry");
  if (!en || !en->json().is_array()) f.fail_at("entry", "expected an array of [block, p]");
  for (const JsonField& x : en->elements()) {
    if (!is_tuple(x.json(), 2)) x.fail("expected [block, p]");
    const int blk = x.json()[0].get<int>();
    if (blk < 0 || blk >= nb) x.fail("unknown block " + std::to_string(blk));
    const double pr = finite_number(x.element(1));
    if (pr < 0 || pr > 1) x.element(1).fail("probability outside [0, 1]");
    sum += pr;
    key.entry.emplace_back(blk, pr);
  }
  if (std::abs(sum - 1) > kSumTolerance)
    en->fail("background + entry probabilities sum to " + std::to_string(sum) + ", not 1");
  return key;
}

}  // namespace

std::uint64_t SceneProfile::tile_pixels(int t) const {
  const int tx = t % tiles_x, ty = t / tiles_x;
  const int w0 = width / tiles_x, h0 = height / tiles_y;
  const int w = tx + 1 == tiles_x ? width - w0 * (tiles_x - 1) : w0;
  const int h = ty + 1 == tiles_y ? height - h0 * (tiles_y - 1) : h0;
  return static_cast<std::uint64_t>(w) * static_cast<std::uint64_t>(h);
}

Bytes SceneProfile::scene_bytes() const {
  Bytes t = 0;
  for (const ProfileBlock& b : blocks) t += b.bytes;
  return t;
}

SceneProfile parse_scene_profile(const std::string& text, const std::string& file) {
  const JsonInput input(file);
  const json doc = input.parse(text);
  const JsonField root = input.field(doc, "");
  SceneProfile p;
  p.file = file;
  header(root, p);
  if (const auto f = root.find("image")) image(*f, p);
  if (const auto f = root.find("batching")) batching(*f, p);
  if (const auto f = root.find("records")) records(*f, p);
  if (const auto f = root.find("analytic")) analytic(*f, p.analytic);
  const std::vector<JsonField> blocks = block_list(root);
  const int nb = static_cast<int>(blocks.size());
  for (int i = 0; i < nb; ++i) p.blocks.push_back(block(blocks[static_cast<std::size_t>(i)], i, nb));
  check_symmetric(input, p);
  const auto cp = root.find("camera_path");
  if (!cp || !cp->json().is_array() || cp->json().empty()) input.fail("camera_path", "expected a non-empty array");
  for (const JsonField& k : cp->elements()) p.camera_path.push_back(camera_key(k, nb));
  return p;
}

SceneProfile load_scene_profile(const std::string& path) {
  std::ifstream in = open_input(path, "scene profile");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_scene_profile(ss.str(), path);
}

}  // namespace rayline
