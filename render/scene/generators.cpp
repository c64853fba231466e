// Generator registry, the small test fixtures (cornell, furnace, block-crossing),
// writing a generated mesh + companion scene, and the built-in default scene.
#include "render/scene/generators.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>

#include "render/scene/builder.hpp"
#include "render/scene/ply_writer.hpp"
#include "render/scene/rng.hpp"
#include "common/error.hpp"
#include "common/unfinished_output.hpp"

namespace rayline::scene {
namespace {

// ---- cornell: a 1 m Cornell-box-like room, open at +z; light as an AreaLight --------
// Slots: 0 white, 1 red, 2 green. Walls and blocks are n × n grids; the floor is an
// exact patch taking the rest of the budget.
void emit_cornell(std::uint64_t triangles, std::uint64_t, MeshSink& out) {
  BudgetSink sink(out);
  MeshBuilder mb;
  const int n = std::max(1, int(std::sqrt(double(triangles) / 34.0)));
  mb.grid({0, 1, 0}, {1, 0, 0}, {0, 0, 1}, n, n);  // ceiling
  mb.grid({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, n, n);  // back
  const Affine tall = Affine::translate({0.33f, 0.3f, 0.38f}) * Affine::rotate({0, 1, 0}, 17) *
                      Affine::scale({0.15f, 0.3f, 0.15f});
  const Affine low = Affine::translate({0.67f, 0.15f, 0.65f}) * Affine::rotate({0, 1, 0}, -18) *
                     Affine::scale({0.15f, 0.15f, 0.15f});
  mb.box(tall, n), mb.box(low, n);
  mb.flush(sink, 0);
  mb.grid({0, 0, 0}, {0, 1, 0}, {0, 0, 1}, n, n);  // left
  mb.flush(sink, 1);
  mb.grid({1, 0, 0}, {0, 0, 1}, {0, 1, 0}, n, n);  // right
  mb.flush(sink, 2);
  mb.exact_patch(triangles - sink.emitted - 0, {0, 0, 0}, {0, 0, 1}, {1, 0, 0});  // floor
  mb.flush(sink, 0);
}

void describe_cornell(Scene& s, const Bounds&) {
  s.materials = {{"white", {0.73f, 0.73f, 0.73f}, {}},
                 {"red", {0.65f, 0.05f, 0.05f}, {}},
                 {"green", {0.12f, 0.45f, 0.15f}, {}}};
  s.area_lights = {{"ceiling", {0.4f, 0.998f, 0.4f}, {0.2f, 0, 0}, {0, 0, 0.2f}, {17, 12, 4}}};
  s.environment.radiance = {0, 0, 0};
  Camera c;
  c.name = "main", c.position = {0.5f, 0.5f, 1.94f}, c.look_at = {0.5f, 0.5f, 0}, c.fov_y_deg = 39.3f;
  s.cameras = {c};
  CameraPath p;
  p.name = "dolly", p.frames = 30;
  CameraKey k0{0, c}, k1{1, c};
  k1.camera.position = {0.5f, 0.5f, 1.2f};
  p.keys = {k0, k1};
  s.camera_paths = {p};
}

// ---- furnace: closed unit sphere (albedo a, emission Le: radiance Le / (1 - a)) -------
// A flat plate of the same material inside the sphere takes the remainder of the budget;
// any closed configuration of one uniform material keeps the analytic answer.
void emit_furnace(std::uint64_t triangles, std::uint64_t, MeshSink& out) {
  BudgetSink sink(out);
  const int g = std::max(1, int(std::sqrt(double(triangles) / 12.0)));
  emit_cube_sphere(sink, std::uint64_t(12) * g * g, 0, [](Float3 d) { return d; });
  MeshBuilder mb;
  mb.exact_patch(triangles - sink.emitted, {-0.3f, -0.8f, -0.3f}, {0, 0, 0.6f}, {0.6f, 0, 0});
  mb.flush(sink, 0);
}

void describe_furnace(Scene& s, const Bounds&) {
  s.materials = {{"shell", {0.5f, 0.5f, 0.5f}, {0.5f, 0.5f, 0.5f}}};
  s.area_lights.clear();
  s.environment.radiance = {0, 0, 0};
  Camera c;
  c.name = "inside", c.position = {0, 0, 0}, c.look_at = {0, 0, -1}, c.fov_y_deg = 60, c.width = c.height = 64;
  s.cameras = {c};
  s.camera_paths.clear();
}

// ---- block-crossing: small random triangles spread through a 2 m cube --------------
// Total area 16 m² whatever the count: a ray's mean free path is about the cube's
// width, so most rays cross many kd-tree cells before they hit.
void emit_block_crossing(std::uint64_t triangles, std::uint64_t seed, MeshSink& out) {
  Rng rng(seed);
  const float edge = std::sqrt(4.0f * 16.0f / (std::sqrt(3.0f) * float(triangles)));
  MeshBuilder mb;
  for (std::uint64_t i = 0; i < triangles; ++i) {
    const Float3 c{rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)};
    const Float3 nrm = rng.unit_vector();
    const Float3 t = normalize(cross(nrm, std::abs(nrm.x) < 0.9f ? Float3{1, 0, 0} : Float3{0, 1, 0}));
    const Float3 b = cross(nrm, t);
    const float r = edge / std::sqrt(3.0f);
    const std::uint32_t v0 = mb.vertex(c + t * r);
    const std::uint32_t v1 = mb.vertex(c + (t * -0.5f + b * 0.8660254f) * r);
    const std::uint32_t v2 = mb.vertex(c + (t * -0.5f - b * 0.8660254f) * r);
    mb.tri(v0, v1, v2);
    if (mb.triangle_count() == 16384) mb.flush(out, 0);
  }
  mb.flush(out, 0);
}

void describe_block_crossing(Scene& s, const Bounds&) {
  s.materials = {{"grey", {0.6f, 0.6f, 0.6f}, {}}};
  s.area_lights.clear();
  s.environment.radiance = {1, 1, 1};
  Camera c;
  c.name = "main", c.position = {0.3f, 0.4f, 4.5f}, c.look_at = {0, 0, 0}, c.fov_y_deg = 35;
  s.cameras = {c};
  s.camera_paths.clear();
}

const std::vector<GeneratorInfo> kGenerators = {
    {"museum-like", "two-storey arcaded atrium, open roof, displaced scan-like statues on pedestals", 1'000'000,
     10'000, emit_museum, describe_museum},
    {"boeing-like", "closed fuselage hull packed with posed pipes, brackets, cables, boxes", 1'000'000, 5'000,
     emit_boeing, describe_boeing},
    {"cornell", "Cornell-box-like room with two blocks (test fixture)", 10'000, 64, emit_cornell, describe_cornell},
    {"furnace", "closed unit sphere, albedo 0.5, emission 0.5: radiance 1 everywhere (test fixture)", 10'000, 12,
     emit_furnace, describe_furnace},
    {"block-crossing", "random small triangles in a cube; rays cross many blocks (test fixture)", 100'000, 1,
     emit_block_crossing, describe_block_crossing},
};

void write_text_atomic(const std::string& path, const std::string& text) {
  const std::string tmp = unfinished::fresh_temp_name(path, "tmp");
  const unfinished::Guard unfinished_guard(tmp);  // removed if the run is interrupted
  {
    std::ofstream o(tmp, std::ios::binary | std::ios::trunc);
    if (!o) throw InputError(path, "", "cannot open for writing");
    o << text;
    o.flush();
    if (!o) {
      std::remove(tmp.c_str());
      throw InputError(path, "", "write failed");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::remove(tmp.c_str());
    throw InputError(path, "", "cannot rename temporary file into place");
  }
}

}  // namespace

const std::vector<GeneratorInfo>& all_generators() { return kGenerators; }

const GeneratorInfo* find_generator(const std::string& name) {
  for (const auto& g : kGenerators)
    if (g.name == name) return &g;
  return nullptr;
}

std::string generator_names() {
  std::string s;
  for (const auto& g : kGenerators) s += (s.empty() ? "" : ", ") + g.name;
  return s;
}

void run_generator(const std::string& name, std::uint64_t triangles, std::uint64_t seed, MeshSink& sink) {
  const GeneratorInfo* g = find_generator(name);
  if (!g) throw InputError("generator", "name", "unknown generator '" + name + "' (known: " + generator_names() + ")");
  if (triangles < g->min_triangles)
    throw InputError("generator", "triangles",
                     name + " needs at least " + std::to_string(g->min_triangles) + " triangles");
  g->emit(triangles, seed, sink);
}

Scene generator_scene(const std::string& name, MeshInstance mesh, const Bounds& bounds) {
  const GeneratorInfo* g = find_generator(name);
  if (!g) throw InputError("generator", "name", "unknown generator '" + name + "'");
  Scene s;
  s.source = mesh.file.empty() ? "<generator " + name + ">" : mesh.file;
  g->describe(s, bounds);
  mesh.material = 0;
  mesh.material_slots.clear();
  for (std::uint32_t i = 0; i < s.materials.size(); ++i) mesh.material_slots.push_back(i);
  if (mesh.name.empty()) mesh.name = name;
  s.meshes = {mesh};
  validate(s);
  return s;
}

namespace {

// Passes pieces on to `out` and reports the running triangle count.
class ProgressSink final : public MeshSink {
 public:
  ProgressSink(MeshSink& out, std::uint64_t total, const GenerateProgress& progress)
      : out_(out), total_(total), progress_(progress) {}
  void add(const MeshPiece& p) override {
    out_.add(p);
    done_ += p.triangles.size();
    progress_(done_, total_);
  }

 private:
  MeshSink& out_;
  std::uint64_t total_, done_ = 0;
  const GenerateProgress& progress_;
};

}  // namespace

GenerateResult generate_to_file(const std::string& name, std::uint64_t triangles, std::uint64_t seed,
                                const std::string& out, const std::string& scene_out,
                                const GenerateProgress& progress) {
  if (!find_generator(name))
    throw InputError("generator", "name", "unknown generator '" + name + "' (known: " + generator_names() + ")");
  namespace fs = std::filesystem;
  GenerateResult r;
  r.mesh_path = out;
  {
    PlyWriter w(out, {"generator " + name, "triangles " + std::to_string(triangles), "seed " + std::to_string(seed)});
    if (progress) {
      ProgressSink counted(w, triangles, progress);
      run_generator(name, triangles, seed, counted);
    } else {
      run_generator(name, triangles, seed, w);
    }
    w.finish();
    r.triangles = w.triangle_count(), r.vertices = w.vertex_count(), r.bounds = w.bounds();
  }
  if (scene_out != "-") {
    r.scene_path = scene_out.empty() ? fs::path(out).replace_extension(".json").string() : scene_out;
    if (fs::absolute(r.scene_path) == fs::absolute(out))
      throw InputError(out, "", "mesh and companion scene would share a name");
    MeshInstance m;
    m.name = name;
    m.file = fs::absolute(out).lexically_normal().string();
    const Scene s = generator_scene(name, m, r.bounds);
    write_text_atomic(r.scene_path, scene_to_json(s, fs::absolute(r.scene_path).parent_path().string()));
  }
  return r;
}

Scene default_scene() {
  MeshInstance m;
  m.name = "cornell";
  m.generator = "cornell";
  m.triangles = find_generator("cornell")->default_triangles;
  m.seed = 1;
  Bounds b;
  b.extend(Float3{0, 0, 0}), b.extend(Float3{1, 1, 1});
  Scene s = generator_scene("cornell", m, b);
  s.source = "<built-in>";
  return s;
}

}  // namespace rayline::scene
