// Scene JSON reading and writing (the only place nlohmann_json touches scenes). Reading
// goes through common/json_fields.hpp, one function per section of the format.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "render/scene/file_type.hpp"
#include "render/scene/generators.hpp"
#include "render/scene/mesh_import.hpp"
#include "render/scene/scene.hpp"
#include "common/error.hpp"
#include "common/json_fields.hpp"

namespace rayline::scene {
namespace {

using Json = nlohmann::ordered_json;
using Field = OrderedJsonField;
namespace fs = std::filesystem;

// Scene files say what a field must be ("must be a number") and call keys fields.
constexpr JsonWording kWording{.type_prefix = "must be ",
                               .name_actual_type = false,
                               .unknown_key = "unknown field",
                               .list_allowed_keys = false,
                               .top_level = ""};

// An integer; a float with an integral value (1.0, 2e3) counts as one.
std::int64_t integer(const Field& f) {
  const Json& j = f.json();
  if (j.is_number_integer()) return j.get<std::int64_t>();
  if (j.is_number_float() && j.get<double>() == std::floor(j.get<double>()) && std::abs(j.get<double>()) < 9e15)
    return static_cast<std::int64_t>(j.get<double>());
  f.fail("must be an integer");
}

// `f` reported at `path` (a few messages name the enclosing field, not the element).
Field renamed(const Field& f, const std::string& path) { return Field(f.input(), f.json(), path); }

float number(const Field& f) { return float(f.number()); }

Float3 vec3(const Field& f) {
  if (!f.json().is_array() || f.size() != 3) f.fail("must be an array of 3 numbers");
  return {number(f.element(0)), number(f.element(1)), number(f.element(2))};
}

// A colour: [r, g, b] or one number for grey.
Float3 color(const Field& f) {
  if (!f.json().is_number()) return vec3(f);
  const float v = float(f.json().get<double>());
  return {v, v, v};
}

// 12 or 16 numbers, row-major; the last row of 16 must be 0 0 0 1 (affine).
Affine matrix(const Field& m, const std::string& transform) {
  if (!m.json().is_array() || (m.size() != 12 && m.size() != 16)) m.fail("must hold 12 or 16 numbers (row-major)");
  Affine a;
  for (std::size_t r = 0; r < 3; ++r)
    for (std::size_t c = 0; c < 4; ++c) a.m[r][c] = number(renamed(m.element(r * 4 + c), m.path()));
  if (m.size() != 16) return a;
  auto last = [&](std::size_t k) { return renamed(m.element(k), transform).number(); };
  if (last(12) != 0 || last(13) != 0 || last(14) != 0 || last(15) != 1) m.fail("last row must be 0 0 0 1 (affine)");
  return a;
}

Affine rotation(const Field& r) {
  r.only_keys({"axis", "deg"});
  if (!r.has("axis") || !r.has("deg")) r.fail("needs \"axis\" and \"deg\"");
  const Float3 axis = vec3(r.at("axis"));
  if (!(length(axis) > 0)) r.at("axis").fail("must not be zero");
  return Affine::rotate(axis, number(r.at("deg")));
}

// Applied in the order matrix, scale, rotate, translate.
Affine transform(const Field& f) {
  f.only_keys({"matrix", "scale", "rotate", "translate"});
  Affine a;
  if (const auto m = f.find("matrix")) a = matrix(*m, f.path());
  if (const auto s = f.find("scale")) {
    const Float3 v = s->json().is_number() ? Float3{number(*s), number(*s), number(*s)} : vec3(*s);
    if (v.x == 0 || v.y == 0 || v.z == 0) s->fail("must not be zero");
    a = Affine::scale(v) * a;
  }
  if (const auto r = f.find("rotate")) a = rotation(*r) * a;
  if (const auto t = f.find("translate")) a = Affine::translate(vec3(*t)) * a;
  return a;
}

void resolution(const Field& r, Camera& c) {
  if (!r.json().is_array() || r.size() != 2) r.fail("must be [width, height]");
  const auto w = integer(renamed(r.element(0), r.path())), h = integer(renamed(r.element(1), r.path()));
  if (w < 1 || h < 1 || w > 65536 || h > 65536) r.fail("must be in [1, 65536]");
  c.width = int(w), c.height = int(h);
}

// A camera, or a camera path key (which may also name a "camera" and a time "t").
Camera camera(const Field& f, const std::string& name, const Camera& base) {
  f.only_keys({"position", "look_at", "up", "fov_deg", "resolution", "t", "camera"});
  Camera c = base;
  c.name = name;
  if (const auto v = f.find("position")) c.position = vec3(*v);
  if (const auto v = f.find("look_at")) c.look_at = vec3(*v);
  if (const auto v = f.find("up")) c.up = vec3(*v);
  if (const auto v = f.find("fov_deg")) c.fov_y_deg = number(*v);
  if (const auto v = f.find("resolution")) resolution(*v, c);
  return c;
}

// Materials, by name (file order kept).
void materials(const Field& root, Scene& s) {
  const auto ms = root.find("materials");
  if (!ms) return;
  if (!ms->json().is_object()) ms->fail("must be an object of name: {albedo, emission}");
  for (const auto& [name, f] : ms->members()) {
    f.only_keys({"albedo", "emission"});
    Material m;
    m.name = name;
    if (const auto v = f.find("albedo")) m.albedo = color(*v);
    if (const auto v = f.find("emission")) m.emission = color(*v);
    s.materials.push_back(m);
  }
}

std::uint32_t material_ref(const Field& f, const Scene& s) {
  const std::string name = f.string();
  if (auto i = s.find_material(name)) return *i;
  f.fail("unknown material '" + name + "' (dangling reference)");
}

void mesh_file(const Field& f, const fs::path& dir, MeshInstance& m) {
  fs::path p = f.at("file").string();
  if (p.is_relative()) p = dir / p;
  m.file = p.lexically_normal().string();
  std::error_code ec;
  if (!fs::is_regular_file(m.file, ec)) {
    // A missing file keeps its short message; a folder, FIFO, device or link loop says what it is.
    const std::string why = fs::exists(fs::symlink_status(m.file, ec)) ? not_a_regular_file(m.file, "mesh file") : "";
    f.at("file").fail(why.empty() ? "mesh file not found: " + m.file : m.file + " " + why);
  }
  if (f.has("triangles") || f.has("seed")) f.fail("\"triangles\"/\"seed\" only apply to generators");
}

void mesh_generator(const Field& f, MeshInstance& m) {
  m.generator = f.at("generator").string();
  const GeneratorInfo* g = find_generator(m.generator);
  if (!g) f.at("generator").fail("unknown generator '" + m.generator + "' (known: " + generator_names() + ")");
  m.triangles = g->default_triangles;
  if (const auto t = f.find("triangles")) {
    const auto n = integer(*t);
    if (n < 1 || n > 4'000'000'000LL) t->fail("must be in [1, 4e9]");
    m.triangles = std::uint64_t(n);
  }
  if (const auto sd = f.find("seed")) {
    const auto n = integer(*sd);
    if (n < 0) sd->fail("must be >= 0");
    m.seed = std::uint64_t(n);
  }
}

// A mesh without "material" gets UINT32_MAX here and the default material afterwards.
MeshInstance mesh(const Field& f, std::size_t i, const fs::path& dir, const Scene& s) {
  f.only_keys({"name", "file", "generator", "triangles", "seed", "transform", "material", "material_slots"});
  MeshInstance m;
  m.name = f.has("name") ? f.at("name").string() : "mesh" + std::to_string(i);
  if (f.has("file") == f.has("generator")) f.fail("needs exactly one of \"file\" and \"generator\"");
  if (f.has("file")) mesh_file(f, dir, m);
  else mesh_generator(f, m);
  if (const auto t = f.find("transform")) m.transform = transform(*t);
  m.material = f.has("material") ? material_ref(f.at("material"), s) : UINT32_MAX;
  if (const auto sl = f.find("material_slots")) {
    if (!sl->json().is_array()) sl->fail("must be an array of material names");
    for (const Field& slot : sl->elements()) m.material_slots.push_back(material_ref(slot, s));
  }
  return m;
}

void meshes(const Field& root, const fs::path& dir, Scene& s) {
  if (!root.has("meshes")) root.fail_at("meshes", "missing (a scene needs at least one mesh)");
  bool needs_default = false;
  for (const Field& f : root.at("meshes").elements()) {
    s.meshes.push_back(mesh(f, s.meshes.size(), dir, s));
    needs_default = needs_default || s.meshes.back().material == UINT32_MAX;
  }
  if (!needs_default) return;
  auto d = s.find_material("default");
  if (!d) {
    s.materials.push_back({"default", {0.7f, 0.7f, 0.7f}, {0, 0, 0}});
    d = std::uint32_t(s.materials.size() - 1);
  }
  for (auto& m : s.meshes)
    if (m.material == UINT32_MAX) m.material = *d;
}

AreaLight area_light(const Field& f, std::size_t i) {
  f.only_keys({"type", "name", "corner", "edge_u", "edge_v", "emission"});
  AreaLight l;
  l.name = f.has("name") ? f.at("name").string() : "light" + std::to_string(i);
  for (const char* k : {"corner", "edge_u", "edge_v", "emission"})
    if (!f.has(k)) f.fail_at(k, "missing");
  l.corner = vec3(f.at("corner"));
  l.edge_u = vec3(f.at("edge_u"));
  l.edge_v = vec3(f.at("edge_v"));
  l.emission = color(f.at("emission"));
  return l;
}

void lights(const Field& root, Scene& s) {
  const auto ls = root.find("lights");
  if (!ls) return;
  bool env = false;
  const std::vector<Field> list = ls->elements();
  for (std::size_t i = 0; i < list.size(); ++i) {
    const Field& f = list[i];
    if (!f.has("type")) f.fail_at("type", "missing (\"area\" or \"environment\")");
    const std::string type = f.at("type").string();
    if (type == "area") {
      s.area_lights.push_back(area_light(f, i));
    } else if (type == "environment") {
      f.only_keys({"type", "name", "radiance"});
      if (env) f.fail("only one environment light is allowed");
      env = true;
      s.environment.radiance = color(f.at("radiance"));
    } else {
      f.at("type").fail("unknown light type '" + type + "' (\"area\" or \"environment\")");
    }
  }
}

// Cameras (the first is the default).
void cameras(const Field& root, Scene& s) {
  if (!root.has("cameras")) root.fail_at("cameras", "missing (a scene needs at least one camera)");
  const Field cs = root.at("cameras");
  if (!cs.json().is_object() || cs.json().empty()) cs.fail("must be a non-empty object of name: camera");
  for (const auto& [name, f] : cs.members()) {
    f.only_keys({"position", "look_at", "up", "fov_deg", "resolution"});
    s.cameras.push_back(camera(f, name, Camera{}));
  }
}

const Camera* find_camera(const Scene& s, const std::string& name) {
  for (auto& c : s.cameras)
    if (c.name == name) return &c;
  return nullptr;
}

// A key starts from a named camera, or from the default one when it gives a position.
CameraKey camera_key(const Field& f, const std::string& path_name, const Scene& s) {
  if (!f.has("t")) f.fail_at("t", "missing");
  CameraKey key;
  key.time = f.at("t").number();
  Camera base = s.cameras.front();
  if (const auto cn = f.find("camera")) {
    const Camera* c = find_camera(s, cn->string());
    if (!c) cn->fail("unknown camera '" + cn->string() + "' (dangling reference)");
    base = *c;
  } else if (!f.has("position")) {
    f.fail("needs \"camera\" or \"position\"");
  }
  key.camera = camera(f, path_name, base);
  return key;
}

CameraPath camera_path(const Field& f, const std::string& name, const Scene& s) {
  f.only_keys({"frames", "interpolation", "keys"});
  CameraPath p;
  p.name = name;
  const auto frames = integer(f.at("frames"));
  if (frames < 1 || frames > 10'000'000) f.at("frames").fail("must be in [1, 1e7]");
  p.frames = int(frames);
  if (const auto in = f.find("interpolation")) {
    const std::string mode = in->string();
    if (mode == "linear") p.interpolation = Interpolation::linear;
    else if (mode == "catmull-rom") p.interpolation = Interpolation::catmull_rom;
    else in->fail("unknown '" + mode + "' (\"linear\" or \"catmull-rom\")");
  }
  const auto keys = f.find("keys");
  if (!keys || !keys->json().is_array() || keys->json().empty()) f.fail_at("keys", "must be a non-empty array");
  for (const Field& k : keys->elements()) p.keys.push_back(camera_key(k, p.name, s));
  return p;
}

void camera_paths(const Field& root, Scene& s) {
  const auto ps = root.find("camera_paths");
  if (!ps) return;
  if (!ps->json().is_object()) ps->fail("must be an object of name: path");
  for (const auto& [name, f] : ps->members()) s.camera_paths.push_back(camera_path(f, name, s));
}

void render_settings(const Field& root, Scene& s) {
  const auto r = root.find("render");
  if (!r) return;
  r->only_keys({"spp", "max_depth"});
  if (const auto v = r->find("spp")) s.render.spp = int(integer(*v));
  if (const auto v = r->find("max_depth")) s.render.max_depth = int(integer(*v));
}

// A float as the shortest decimal that reads back to it (0.73f → 0.73, not 0.7300000190734863).
double shortest(float f) {
  char buf[32];
  for (int digits = 6; digits <= 9; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, double(f));
    if (std::strtof(buf, nullptr) == f) break;
  }
  return std::strtod(buf, nullptr);
}
Json vec(Float3 v) { return Json::array({shortest(v.x), shortest(v.y), shortest(v.z)}); }

// Puts arrays of numbers on one line: [1, 2, 3].
std::string compact_number_arrays(const std::string& in) {
  std::string out;
  out.reserve(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    if (in[i] == '[') {
      const std::size_t close = in.find_first_of("[]{\"", i + 1);
      if (close != std::string::npos && in[close] == ']') {
        std::string inner;
        bool space = false;
        for (std::size_t k = i + 1; k < close; ++k) {
          const char c = in[k];
          if (c == ' ' || c == '\n') { space = true; continue; }
          if (space && !inner.empty()) inner += ' ';
          space = false;
          inner += c;
        }
        out += '[' + inner + ']';
        i = close;
        continue;
      }
    }
    out += in[i];
  }
  return out;
}

}  // namespace

Scene parse_scene(const std::string& text, const std::string& origin) {
  const OrderedJsonInput input(origin, kWording);
  const Json doc = input.parse(text);
  const Field root = input.field(doc, "");
  root.only_keys({"version", "description", "materials", "meshes", "lights", "cameras", "camera_paths", "render"});
  if (const auto v = root.find("version"); v && integer(*v) != 1)
    v->fail("unsupported scene version (this build reads version 1)");
  const fs::path dir = fs::absolute(fs::path(origin)).parent_path();
  Scene s;
  s.source = origin;
  if (const auto d = root.find("description"); d && d->json().is_string()) s.description = d->string();
  materials(root, s);
  meshes(root, dir, s);
  lights(root, s);
  cameras(root, s);
  camera_paths(root, s);
  render_settings(root, s);
  validate(s);
  return s;
}

Scene load_scene(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw InputError(path, "", "is a folder, not a scene file (give the file's path)");
  // Missing, a FIFO (opening it would block), a device, a symbolic link loop: said as such.
  if (const std::string why = not_a_regular_file(path, "scene file"); !why.empty()) throw InputError(path, "", why);
  std::string ext = fs::path(path).extension().string();
  for (auto& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  if (ext != ".json") {
    if (!is_mesh_file(path)) throw InputError(path, "", "neither a scene (.json) nor a mesh format assimp reads");
    return frame_mesh(path, mesh_file_stats(path).bounds);
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open scene file");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_scene(ss.str(), path);
}

std::string scene_to_json(const Scene& s, const std::string& relative_to) {
  Json j;
  j["version"] = 1;
  if (!s.description.empty()) j["description"] = s.description;
  Json ms = Json::object();
  for (const auto& m : s.materials) ms[m.name] = {{"albedo", vec(m.albedo)}, {"emission", vec(m.emission)}};
  j["materials"] = ms;
  Json meshes = Json::array();
  for (const auto& m : s.meshes) {
    Json mj;
    mj["name"] = m.name;
    if (!m.file.empty()) {
      std::string file = m.file;
      if (!relative_to.empty()) {
        const fs::path rel = fs::absolute(m.file).lexically_relative(fs::absolute(relative_to));
        if (!rel.empty() && rel.native().rfind("..", 0) != 0) file = rel.string();
      }
      mj["file"] = file;
    } else {
      mj["generator"] = m.generator;
      mj["triangles"] = m.triangles;
      mj["seed"] = m.seed;
    }
    if (!m.transform.is_identity()) {
      Json mat = Json::array();
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) mat.push_back(shortest(m.transform.m[r][c]));
      mj["transform"] = {{"matrix", mat}};
    }
    mj["material"] = s.materials.at(m.material).name;
    if (!m.material_slots.empty()) {
      Json sl = Json::array();
      for (auto i : m.material_slots) sl.push_back(s.materials.at(i).name);
      mj["material_slots"] = sl;
    }
    meshes.push_back(mj);
  }
  j["meshes"] = meshes;
  Json lights = Json::array();
  for (const auto& l : s.area_lights)
    lights.push_back({{"type", "area"}, {"name", l.name}, {"corner", vec(l.corner)}, {"edge_u", vec(l.edge_u)},
                      {"edge_v", vec(l.edge_v)}, {"emission", vec(l.emission)}});
  lights.push_back({{"type", "environment"}, {"radiance", vec(s.environment.radiance)}});
  j["lights"] = lights;
  auto camera_json = [](const Camera& c) {
    return Json{{"position", vec(c.position)}, {"look_at", vec(c.look_at)}, {"up", vec(c.up)},
                {"fov_deg", shortest(c.fov_y_deg)}, {"resolution", {c.width, c.height}}};
  };
  Json cams = Json::object();
  for (const auto& c : s.cameras) cams[c.name] = camera_json(c);
  j["cameras"] = cams;
  if (!s.camera_paths.empty()) {
    Json paths = Json::object();
    for (const auto& p : s.camera_paths) {
      Json keys = Json::array();
      for (const auto& k : p.keys) {
        Json kj = camera_json(k.camera);
        kj.erase("resolution");
        kj["t"] = k.time;
        keys.push_back(kj);
      }
      paths[p.name] = {{"frames", p.frames},
                       {"interpolation", p.interpolation == Interpolation::linear ? "linear" : "catmull-rom"},
                       {"keys", keys}};
    }
    j["camera_paths"] = paths;
  }
  j["render"] = {{"spp", s.render.spp}, {"max_depth", s.render.max_depth}};
  return compact_number_arrays(j.dump(2)) + "\n";
}

}  // namespace rayline::scene
