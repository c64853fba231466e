// JSON reader of scene profiles (schema: docs/scene-profiles.md). Every error names the
// file and the field, e.g. `boeing.profile.json: blocks[3].neighbours[1]: unknown block 200`.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "common/error.hpp"
#include "common/input_file.hpp"
#include "workload/scene_profile.hpp"

namespace rayline {

using nlohmann::json;

namespace {

constexpr double kSumTolerance = 1e-6;

struct Reader {
  const std::string& file;

  void keys(const json& obj, const std::set<std::string>& allowed, const std::string& field) const {
    if (!obj.is_object()) throw InputError(file, field, "expected an object");
    for (auto it = obj.begin(); it != obj.end(); ++it)
      if (!allowed.count(it.key())) throw InputError(file, field.empty() ? it.key() : field + "." + it.key(), "unknown key");
  }
  static std::string join(const std::string& field, const std::string& key) { return field.empty() ? key : field + "." + key; }

  double number(const json& v, const std::string& field) const {
    if (!v.is_number()) throw InputError(file, field, "expected a number");
    const double x = v.get<double>();
    if (!std::isfinite(x)) throw InputError(file, field, "must be finite");
    return x;
  }
  double probability(const json& obj, const char* key, const std::string& field, double dflt = -1) const {
    auto it = obj.find(key);
    if (it == obj.end()) {
      if (dflt >= 0) return dflt;
      throw InputError(file, join(field, key), "missing");
    }
    const double p = number(*it, join(field, key));
    if (p < 0 || p > 1) throw InputError(file, join(field, key), "probability " + std::to_string(p) + " outside [0, 1]");
    return p;
  }
  // A size or count: an integer > 0 (sizes may not be negative or zero).
  std::uint64_t positive(const json& obj, const char* key, const std::string& field, std::uint64_t dflt) const {
    auto it = obj.find(key);
    if (it == obj.end()) return dflt;
    const std::string f = join(field, key);
    if (!it->is_number()) throw InputError(file, f, "expected a number");
    const double x = it->get<double>();
    if (!(x > 0)) throw InputError(file, f, "must be > 0 (got " + it->dump() + ")");
    if (!it->is_number_integer() && !it->is_number_unsigned()) throw InputError(file, f, "expected an integer");
    return it->get<std::uint64_t>();
  }
  // An optional string field ("" when absent).
  std::string text(const json& obj, const char* key) const {
    auto it = obj.find(key);
    if (it == obj.end()) return {};
    if (!it->is_string()) throw InputError(file, key, "expected a string");
    return it->get<std::string>();
  }
  std::array<double, 3> vec3(const json& obj, const char* key, const std::string& field) const {
    auto it = obj.find(key);
    const std::string f = join(field, key);
    if (it == obj.end()) throw InputError(file, f, "missing");
    if (!it->is_array() || it->size() != 3) throw InputError(file, f, "expected [x, y, z]");
    return {number((*it)[0], f + "[0]"), number((*it)[1], f + "[1]"), number((*it)[2], f + "[2]")};
  }
};

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
  json root;
  try {
    root = json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError(file, "", std::string("invalid JSON: ") + e.what());
  }
  const Reader r{file};
  r.keys(root, {"format", "version", "name", "description", "provenance", "image", "batching", "records", "analytic",
                "block_count", "blocks", "camera_path"},
         "");
  if (!root.contains("format") || r.text(root, "format") != "rayline-scene-profile")
    throw InputError(file, "format", "expected \"rayline-scene-profile\"");
  if (auto v = root.find("version"); v == root.end() || !v->is_number_integer() || *v != 1)
    throw InputError(file, "version", "expected 1");
  SceneProfile p;
  p.file = file;
  p.name = r.text(root, "name");
  p.provenance = r.text(root, "provenance");
  (void)r.text(root, "description");

  if (auto it = root.find("image"); it != root.end()) {
    r.keys(*it, {"width", "height", "spp", "tiles"}, "image");
    p.width = static_cast<int>(r.positive(*it, "width", "image", 512));
    p.height = static_cast<int>(r.positive(*it, "height", "image", 512));
    p.spp = static_cast<int>(r.positive(*it, "spp", "image", 4));
    if (auto t = it->find("tiles"); t != it->end()) {
      if (!t->is_array() || t->size() != 2 || !(*t)[0].is_number_integer() || !(*t)[1].is_number_integer())
        throw InputError(file, "image.tiles", "expected [tiles_x, tiles_y]");
      p.tiles_x = (*t)[0].get<int>();
      p.tiles_y = (*t)[1].get<int>();
      if (p.tiles_x < 1 || p.tiles_y < 1 || p.tiles_x > p.width || p.tiles_y > p.height || p.tiles() > 4096)
        throw InputError(file, "image.tiles", "must be >= 1, fit the image, and number at most 4096");
    }
  }
  if (auto it = root.find("batching"); it != root.end()) {
    r.keys(*it, {"wave_rays", "inflight_rays", "max_bounces"}, "batching");
    p.wave_rays = r.positive(*it, "wave_rays", "batching", p.wave_rays);
    p.inflight_rays = r.positive(*it, "inflight_rays", "batching", p.inflight_rays);
    p.max_bounces = static_cast<int>(r.positive(*it, "max_bounces", "batching", static_cast<std::uint64_t>(p.max_bounces)));
    if (p.max_bounces > 200) throw InputError(file, "batching.max_bounces", "at most 200");
  }
  if (auto it = root.find("records"); it != root.end()) {
    r.keys(*it, {"ray_bytes", "shadow_ray_bytes", "hit_bytes", "sample_bytes", "framebuffer_bytes_per_pixel", "request_bytes"},
           "records");
    p.ray_bytes = r.positive(*it, "ray_bytes", "records", p.ray_bytes);
    p.shadow_ray_bytes = r.positive(*it, "shadow_ray_bytes", "records", p.shadow_ray_bytes);
    p.hit_bytes = r.positive(*it, "hit_bytes", "records", p.hit_bytes);
    p.sample_bytes = r.positive(*it, "sample_bytes", "records", p.sample_bytes);
    p.framebuffer_bytes_per_pixel = r.positive(*it, "framebuffer_bytes_per_pixel", "records", p.framebuffer_bytes_per_pixel);
    p.request_bytes = r.positive(*it, "request_bytes", "records", p.request_bytes);
  }
  if (auto it = root.find("analytic"); it != root.end()) {
    r.keys(*it, {"alpha", "beta", "shadow_occlusion", "shadow_exit"}, "analytic");
    p.analytic.alpha = r.probability(*it, "alpha", "analytic", p.analytic.alpha);
    p.analytic.beta = r.probability(*it, "beta", "analytic", p.analytic.beta);
    p.analytic.shadow_occlusion = r.probability(*it, "shadow_occlusion", "analytic", p.analytic.shadow_occlusion);
    p.analytic.shadow_exit = r.probability(*it, "shadow_exit", "analytic", p.analytic.shadow_exit);
  }

  auto bl = root.find("blocks");
  if (bl == root.end() || !bl->is_array() || bl->empty()) throw InputError(file, "blocks", "expected a non-empty array");
  auto bc = root.find("block_count");
  if (bc == root.end() || !bc->is_number_integer()) throw InputError(file, "block_count", "expected an integer");
  if (bc->get<std::int64_t>() != static_cast<std::int64_t>(bl->size()))
    throw InputError(file, "block_count", "says " + bc->dump() + " but the file lists " + std::to_string(bl->size()) + " blocks");
  const int nb = static_cast<int>(bl->size());
  for (int i = 0; i < nb; ++i) {
    const std::string f = "blocks[" + std::to_string(i) + "]";
    const json& o = (*bl)[static_cast<std::size_t>(i)];
    r.keys(o, {"id", "bytes", "lo", "hi", "boundary_area", "alpha", "beta", "escape", "shadow_occlusion", "shadow_exit",
               "neighbours", "triangles"},
           f);
    if (o.contains("id") && o["id"] != i) throw InputError(file, f + ".id", "must equal the block's position " + std::to_string(i));
    ProfileBlock b;
    if (!o.contains("bytes")) throw InputError(file, f + ".bytes", "missing");
    b.bytes = r.positive(o, "bytes", f, 0);
    b.lo = r.vec3(o, "lo", f);
    b.hi = r.vec3(o, "hi", f);
    for (int a = 0; a < 3; ++a)
      if (b.hi[static_cast<std::size_t>(a)] < b.lo[static_cast<std::size_t>(a)])
        throw InputError(file, f + ".hi", "below lo");
    b.boundary_area = o.contains("boundary_area") ? r.number(o["boundary_area"], f + ".boundary_area") : 0.0;
    if (b.boundary_area < 0) throw InputError(file, f + ".boundary_area", "must be >= 0");
    b.alpha = r.probability(o, "alpha", f);
    b.beta = r.probability(o, "beta", f);
    b.escape = r.probability(o, "escape", f);
    b.shadow_occlusion = r.probability(o, "shadow_occlusion", f);
    b.shadow_exit = r.probability(o, "shadow_exit", f);
    auto ns = o.find("neighbours");
    if (ns == o.end() || !ns->is_array()) throw InputError(file, f + ".neighbours", "expected an array of [block, area, p]");
    double psum = 0;
    std::set<int> seen;
    for (std::size_t k = 0; k < ns->size(); ++k) {
      const std::string nf = f + ".neighbours[" + std::to_string(k) + "]";
      const json& e = (*ns)[k];
      if (!e.is_array() || e.size() != 3 || !e[0].is_number_integer()) throw InputError(file, nf, "expected [block, area, p]");
      ProfileNeighbour n;
      n.block = e[0].get<int>();
      if (n.block < 0 || n.block >= nb) throw InputError(file, nf, "unknown block " + std::to_string(n.block));
      if (n.block == i) throw InputError(file, nf, "a block is not its own neighbour");
      if (!seen.insert(n.block).second) throw InputError(file, nf, "neighbour " + std::to_string(n.block) + " listed twice");
      n.area = r.number(e[1], nf + "[1]");
      if (n.area < 0) throw InputError(file, nf + "[1]", "area must be >= 0");
      n.p = r.number(e[2], nf + "[2]");
      if (n.p < 0 || n.p > 1) throw InputError(file, nf + "[2]", "probability outside [0, 1]");
      psum += n.p;
      b.neighbours.push_back(n);
    }
    if (!b.neighbours.empty() && std::abs(psum - 1) > kSumTolerance)
      throw InputError(file, f + ".neighbours", "transition probabilities sum to " + std::to_string(psum) + ", not 1");
    if (b.neighbours.empty() && b.escape < 1 && b.alpha < 1)
      throw InputError(file, f + ".escape", "a block without neighbours must let every missed ray escape (escape = 1)");
    p.blocks.push_back(std::move(b));
  }
  // Symmetry: a neighbour relation goes both ways.
  for (int i = 0; i < nb; ++i)
    for (const ProfileNeighbour& n : p.blocks[static_cast<std::size_t>(i)].neighbours) {
      const auto& back = p.blocks[static_cast<std::size_t>(n.block)].neighbours;
      if (std::none_of(back.begin(), back.end(), [i](const ProfileNeighbour& x) { return x.block == i; }))
        throw InputError(file, "blocks[" + std::to_string(n.block) + "].neighbours",
                         "block " + std::to_string(i) + " lists it as a neighbour but not vice versa");
    }

  auto cp = root.find("camera_path");
  if (cp == root.end() || !cp->is_array() || cp->empty()) throw InputError(file, "camera_path", "expected a non-empty array");
  for (std::size_t k = 0; k < cp->size(); ++k) {
    const std::string f = "camera_path[" + std::to_string(k) + "]";
    const json& o = (*cp)[k];
    r.keys(o, {"background", "entry", "description"}, f);
    CameraKey key;
    key.background = r.probability(o, "background", f, 0.0);
    double sum = key.background;
    auto en = o.find("entry");
    if (en == o.end() || !en->is_array()) throw InputError(file, f + ".entry", "expected an array of [block, p]");
    for (std::size_t e = 0; e < en->size(); ++e) {
      const std::string ef = f + ".entry[" + std::to_string(e) + "]";
      const json& x = (*en)[e];
      if (!x.is_array() || x.size() != 2 || !x[0].is_number_integer()) throw InputError(file, ef, "expected [block, p]");
      const int blk = x[0].get<int>();
      if (blk < 0 || blk >= nb) throw InputError(file, ef, "unknown block " + std::to_string(blk));
      const double pr = r.number(x[1], ef + "[1]");
      if (pr < 0 || pr > 1) throw InputError(file, ef + "[1]", "probability outside [0, 1]");
      sum += pr;
      key.entry.emplace_back(blk, pr);
    }
    if (std::abs(sum - 1) > kSumTolerance)
      throw InputError(file, f + ".entry", "background + entry probabilities sum to " + std::to_string(sum) + ", not 1");
    p.camera_path.push_back(std::move(key));
  }
  return p;
}

SceneProfile load_scene_profile(const std::string& path) {
  std::ifstream in = open_input(path, "scene profile");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_scene_profile(ss.str(), path);
}

}  // namespace rayline
