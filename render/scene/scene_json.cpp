// Scene JSON reading and writing (the only place nlohmann_json touches scenes).
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "render/scene/generators.hpp"
#include "render/scene/mesh_import.hpp"
#include "render/scene/scene.hpp"
#include "common/error.hpp"

namespace rayline::scene {
namespace {

using Json = nlohmann::ordered_json;
namespace fs = std::filesystem;

struct Reader {
  std::string file;

  [[noreturn]] void fail(const std::string& field, const std::string& msg) const { throw InputError(file, field, msg); }

  void only_keys(const Json& j, const std::string& field, std::initializer_list<const char*> keys) const {
    if (!j.is_object()) fail(field, "must be an object");
    for (auto it = j.begin(); it != j.end(); ++it) {
      bool ok = false;
      for (const char* k : keys) ok = ok || it.key() == k;
      if (!ok) fail(field.empty() ? it.key() : field + "." + it.key(), "unknown field");
    }
  }
  double number(const Json& j, const std::string& field) const {
    if (!j.is_number()) fail(field, "must be a number");
    return j.get<double>();
  }
  std::int64_t integer(const Json& j, const std::string& field) const {
    if (j.is_number_integer()) return j.get<std::int64_t>();
    if (j.is_number_float() && j.get<double>() == std::floor(j.get<double>()) && std::abs(j.get<double>()) < 9e15)
      return static_cast<std::int64_t>(j.get<double>());
    fail(field, "must be an integer");
  }
  std::string string(const Json& j, const std::string& field) const {
    if (!j.is_string()) fail(field, "must be a string");
    return j.get<std::string>();
  }
  Float3 vec3(const Json& j, const std::string& field) const {
    if (!j.is_array() || j.size() != 3) fail(field, "must be an array of 3 numbers");
    return {float(number(j[0], field + "[0]")), float(number(j[1], field + "[1]")), float(number(j[2], field + "[2]"))};
  }
  // A colour: [r, g, b] or one number for grey.
  Float3 color(const Json& j, const std::string& field) const {
    if (j.is_number()) {
      const float v = float(j.get<double>());
      return {v, v, v};
    }
    return vec3(j, field);
  }

  Affine transform(const Json& j, const std::string& field) const {
    only_keys(j, field, {"matrix", "scale", "rotate", "translate"});
    Affine a;
    if (j.contains("matrix")) {
      const Json& m = j["matrix"];
      if (!m.is_array() || (m.size() != 12 && m.size() != 16)) fail(field + ".matrix", "must hold 12 or 16 numbers (row-major)");
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) a.m[r][c] = float(number(m[r * 4 + c], field + ".matrix"));
      if (m.size() == 16 && (number(m[12], field) != 0 || number(m[13], field) != 0 || number(m[14], field) != 0 ||
                             number(m[15], field) != 1))
        fail(field + ".matrix", "last row must be 0 0 0 1 (affine)");
    }
    if (j.contains("scale")) {
      const Json& s = j["scale"];
      const Float3 v = s.is_number() ? Float3{float(s.get<double>()), float(s.get<double>()), float(s.get<double>())}
                                     : vec3(s, field + ".scale");
      if (v.x == 0 || v.y == 0 || v.z == 0) fail(field + ".scale", "must not be zero");
      a = Affine::scale(v) * a;
    }
    if (j.contains("rotate")) {
      const Json& r = j["rotate"];
      const std::string rf = field + ".rotate";
      only_keys(r, rf, {"axis", "deg"});
      if (!r.contains("axis") || !r.contains("deg")) fail(rf, "needs \"axis\" and \"deg\"");
      const Float3 axis = vec3(r["axis"], rf + ".axis");
      if (!(length(axis) > 0)) fail(rf + ".axis", "must not be zero");
      a = Affine::rotate(axis, float(number(r["deg"], rf + ".deg"))) * a;
    }
    if (j.contains("translate")) a = Affine::translate(vec3(j["translate"], field + ".translate")) * a;
    return a;
  }

  Camera camera(const Json& j, const std::string& field, const std::string& name, const Camera& base) const {
    only_keys(j, field, {"position", "look_at", "up", "fov_deg", "resolution", "t", "camera"});
    Camera c = base;
    c.name = name;
    if (j.contains("position")) c.position = vec3(j["position"], field + ".position");
    if (j.contains("look_at")) c.look_at = vec3(j["look_at"], field + ".look_at");
    if (j.contains("up")) c.up = vec3(j["up"], field + ".up");
    if (j.contains("fov_deg")) c.fov_y_deg = float(number(j["fov_deg"], field + ".fov_deg"));
    if (j.contains("resolution")) {
      const Json& r = j["resolution"];
      if (!r.is_array() || r.size() != 2) fail(field + ".resolution", "must be [width, height]");
      const auto w = integer(r[0], field + ".resolution"), h = integer(r[1], field + ".resolution");
      if (w < 1 || h < 1 || w > 65536 || h > 65536) fail(field + ".resolution", "must be in [1, 65536]");
      c.width = int(w), c.height = int(h);
    }
    return c;
  }
};

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
  const Reader rd{origin};
  Json j;
  try {
    j = Json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(origin, "", std::string("invalid JSON: ") + e.what());
  }
  rd.only_keys(j, "", {"version", "description", "materials", "meshes", "lights", "cameras", "camera_paths", "render"});
  if (j.contains("version") && rd.integer(j["version"], "version") != 1)
    rd.fail("version", "unsupported scene version (this build reads version 1)");
  const fs::path dir = fs::absolute(fs::path(origin)).parent_path();
  Scene s;
  s.source = origin;
  if (j.contains("description") && j["description"].is_string()) s.description = j["description"].get<std::string>();

  // Materials, by name (file order kept).
  if (j.contains("materials")) {
    const Json& ms = j["materials"];
    if (!ms.is_object()) rd.fail("materials", "must be an object of name: {albedo, emission}");
    for (auto it = ms.begin(); it != ms.end(); ++it) {
      const std::string f = "materials." + it.key();
      rd.only_keys(it.value(), f, {"albedo", "emission"});
      Material m;
      m.name = it.key();
      if (it.value().contains("albedo")) m.albedo = rd.color(it.value()["albedo"], f + ".albedo");
      if (it.value().contains("emission")) m.emission = rd.color(it.value()["emission"], f + ".emission");
      s.materials.push_back(m);
    }
  }
  auto material_ref = [&](const Json& v, const std::string& f) -> std::uint32_t {
    const std::string name = rd.string(v, f);
    if (auto i = s.find_material(name)) return *i;
    rd.fail(f, "unknown material '" + name + "' (dangling reference)");
  };
  bool needs_default = false;

  // Meshes.
  if (!j.contains("meshes")) rd.fail("meshes", "missing (a scene needs at least one mesh)");
  if (!j["meshes"].is_array()) rd.fail("meshes", "must be an array");
  for (std::size_t i = 0; i < j["meshes"].size(); ++i) {
    const Json& mj = j["meshes"][i];
    const std::string f = "meshes[" + std::to_string(i) + "]";
    rd.only_keys(mj, f, {"name", "file", "generator", "triangles", "seed", "transform", "material", "material_slots"});
    MeshInstance m;
    m.name = mj.contains("name") ? rd.string(mj["name"], f + ".name") : "mesh" + std::to_string(i);
    if (mj.contains("file") == mj.contains("generator")) rd.fail(f, "needs exactly one of \"file\" and \"generator\"");
    if (mj.contains("file")) {
      fs::path p = rd.string(mj["file"], f + ".file");
      if (p.is_relative()) p = dir / p;
      m.file = p.lexically_normal().string();
      std::error_code ec;
      if (!fs::is_regular_file(m.file, ec)) rd.fail(f + ".file", "mesh file not found: " + m.file);
      if (mj.contains("triangles") || mj.contains("seed")) rd.fail(f, "\"triangles\"/\"seed\" only apply to generators");
    } else {
      m.generator = rd.string(mj["generator"], f + ".generator");
      const GeneratorInfo* g = find_generator(m.generator);
      if (!g) rd.fail(f + ".generator", "unknown generator '" + m.generator + "' (known: " + generator_names() + ")");
      m.triangles = g->default_triangles;
      if (mj.contains("triangles")) {
        const auto t = rd.integer(mj["triangles"], f + ".triangles");
        if (t < 1 || t > 4'000'000'000LL) rd.fail(f + ".triangles", "must be in [1, 4e9]");
        m.triangles = std::uint64_t(t);
      }
      if (mj.contains("seed")) {
        const auto sd = rd.integer(mj["seed"], f + ".seed");
        if (sd < 0) rd.fail(f + ".seed", "must be >= 0");
        m.seed = std::uint64_t(sd);
      }
    }
    if (mj.contains("transform")) m.transform = rd.transform(mj["transform"], f + ".transform");
    if (mj.contains("material")) m.material = material_ref(mj["material"], f + ".material");
    else needs_default = true, m.material = UINT32_MAX;
    if (mj.contains("material_slots")) {
      const Json& sl = mj["material_slots"];
      if (!sl.is_array()) rd.fail(f + ".material_slots", "must be an array of material names");
      for (std::size_t k = 0; k < sl.size(); ++k)
        m.material_slots.push_back(material_ref(sl[k], f + ".material_slots[" + std::to_string(k) + "]"));
    }
    s.meshes.push_back(m);
  }
  if (needs_default) {
    auto d = s.find_material("default");
    if (!d) {
      s.materials.push_back({"default", {0.7f, 0.7f, 0.7f}, {0, 0, 0}});
      d = std::uint32_t(s.materials.size() - 1);
    }
    for (auto& m : s.meshes)
      if (m.material == UINT32_MAX) m.material = *d;
  }

  // Lights.
  if (j.contains("lights")) {
    if (!j["lights"].is_array()) rd.fail("lights", "must be an array");
    bool env = false;
    for (std::size_t i = 0; i < j["lights"].size(); ++i) {
      const Json& lj = j["lights"][i];
      const std::string f = "lights[" + std::to_string(i) + "]";
      if (!lj.is_object() || !lj.contains("type")) rd.fail(f + ".type", "missing (\"area\" or \"environment\")");
      const std::string type = rd.string(lj["type"], f + ".type");
      if (type == "area") {
        rd.only_keys(lj, f, {"type", "name", "corner", "edge_u", "edge_v", "emission"});
        AreaLight l;
        l.name = lj.contains("name") ? rd.string(lj["name"], f + ".name") : "light" + std::to_string(i);
        for (const char* k : {"corner", "edge_u", "edge_v", "emission"})
          if (!lj.contains(k)) rd.fail(f + "." + k, "missing");
        l.corner = rd.vec3(lj["corner"], f + ".corner");
        l.edge_u = rd.vec3(lj["edge_u"], f + ".edge_u");
        l.edge_v = rd.vec3(lj["edge_v"], f + ".edge_v");
        l.emission = rd.color(lj["emission"], f + ".emission");
        s.area_lights.push_back(l);
      } else if (type == "environment") {
        rd.only_keys(lj, f, {"type", "name", "radiance"});
        if (env) rd.fail(f, "only one environment light is allowed");
        env = true;
        if (!lj.contains("radiance")) rd.fail(f + ".radiance", "missing");
        s.environment.radiance = rd.color(lj["radiance"], f + ".radiance");
      } else {
        rd.fail(f + ".type", "unknown light type '" + type + "' (\"area\" or \"environment\")");
      }
    }
  }

  // Cameras (the first is the default).
  if (!j.contains("cameras")) rd.fail("cameras", "missing (a scene needs at least one camera)");
  if (!j["cameras"].is_object() || j["cameras"].empty()) rd.fail("cameras", "must be a non-empty object of name: camera");
  for (auto it = j["cameras"].begin(); it != j["cameras"].end(); ++it) {
    rd.only_keys(it.value(), "cameras." + it.key(), {"position", "look_at", "up", "fov_deg", "resolution"});
    s.cameras.push_back(rd.camera(it.value(), "cameras." + it.key(), it.key(), Camera{}));
  }
  auto find_camera = [&](const std::string& name) -> const Camera* {
    for (auto& c : s.cameras)
      if (c.name == name) return &c;
    return nullptr;
  };

  // Camera paths.
  if (j.contains("camera_paths")) {
    if (!j["camera_paths"].is_object()) rd.fail("camera_paths", "must be an object of name: path");
    for (auto it = j["camera_paths"].begin(); it != j["camera_paths"].end(); ++it) {
      const std::string f = "camera_paths." + it.key();
      const Json& pj = it.value();
      rd.only_keys(pj, f, {"frames", "interpolation", "keys"});
      CameraPath p;
      p.name = it.key();
      if (!pj.contains("frames")) rd.fail(f + ".frames", "missing");
      const auto frames = rd.integer(pj["frames"], f + ".frames");
      if (frames < 1 || frames > 10'000'000) rd.fail(f + ".frames", "must be in [1, 1e7]");
      p.frames = int(frames);
      if (pj.contains("interpolation")) {
        const std::string in = rd.string(pj["interpolation"], f + ".interpolation");
        if (in == "linear") p.interpolation = Interpolation::linear;
        else if (in == "catmull-rom") p.interpolation = Interpolation::catmull_rom;
        else rd.fail(f + ".interpolation", "unknown '" + in + "' (\"linear\" or \"catmull-rom\")");
      }
      if (!pj.contains("keys") || !pj["keys"].is_array() || pj["keys"].empty())
        rd.fail(f + ".keys", "must be a non-empty array");
      for (std::size_t k = 0; k < pj["keys"].size(); ++k) {
        const Json& kj = pj["keys"][k];
        const std::string kf = f + ".keys[" + std::to_string(k) + "]";
        if (!kj.is_object() || !kj.contains("t")) rd.fail(kf + ".t", "missing");
        CameraKey key;
        key.time = rd.number(kj["t"], kf + ".t");
        Camera base = s.cameras.front();
        if (kj.contains("camera")) {
          const std::string cn = rd.string(kj["camera"], kf + ".camera");
          const Camera* c = find_camera(cn);
          if (!c) rd.fail(kf + ".camera", "unknown camera '" + cn + "' (dangling reference)");
          base = *c;
        } else if (!kj.contains("position")) {
          rd.fail(kf, "needs \"camera\" or \"position\"");
        }
        key.camera = rd.camera(kj, kf, p.name, base);
        p.keys.push_back(key);
      }
      s.camera_paths.push_back(p);
    }
  }

  if (j.contains("render")) {
    rd.only_keys(j["render"], "render", {"spp", "max_depth"});
    if (j["render"].contains("spp")) s.render.spp = int(rd.integer(j["render"]["spp"], "render.spp"));
    if (j["render"].contains("max_depth")) s.render.max_depth = int(rd.integer(j["render"]["max_depth"], "render.max_depth"));
  }
  validate(s);
  return s;
}

Scene load_scene(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, "", "scene file does not exist");
  if (fs::is_directory(path, ec)) throw InputError(path, "", "is a folder, not a scene file (give the file's path)");
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
