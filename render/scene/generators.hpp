// Procedural scenes, deterministic for a seed, streamed piece by piece into a MeshSink
// (bounded memory at any size). `rayline generate NAME --triangles N --out F` writes
// F (binary PLY, ply_writer.hpp) and a companion scene JSON next to it.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "render/scene/mesh_sink.hpp"
#include "render/scene/scene.hpp"

namespace rayline::scene {

struct GeneratorInfo {
  std::string name;
  std::string description;
  std::uint64_t default_triangles;
  std::uint64_t min_triangles;
  // Emits exactly `triangles` triangles (after the min_triangles check).
  void (*emit)(std::uint64_t triangles, std::uint64_t seed, MeshSink& sink);
  // Materials in slot order, lights and cameras for the generated geometry.
  void (*describe)(Scene& scene, const Bounds& bounds);
};

const std::vector<GeneratorInfo>& all_generators();
const GeneratorInfo* find_generator(const std::string& name);
std::string generator_names();  // "a, b, c"

// Runs a generator. Throws InputError("generator", ...) for an unknown name or too few
// triangles.
void run_generator(const std::string& name, std::uint64_t triangles, std::uint64_t seed, MeshSink& sink);

// The companion scene of a generator whose geometry is `mesh` (a file it wrote, or the
// generator itself) with world bounds `bounds`.
Scene generator_scene(const std::string& name, MeshInstance mesh, const Bounds& bounds);

struct GenerateResult {
  std::string mesh_path, scene_path;
  std::uint64_t triangles = 0, vertices = 0;
  Bounds bounds;
};

// Called as the mesh is written: triangles written so far, of `total`.
using GenerateProgress = std::function<void(std::uint64_t done, std::uint64_t total)>;

// Writes the mesh to `out` (binary little-endian PLY, via PATH.tmp.<pid>@<host> and rename) and
// the companion scene to `scene_out` (empty: `out` with extension .json; "-": none).
// `progress`, when set, is called after every piece the generator emits.
GenerateResult generate_to_file(const std::string& name, std::uint64_t triangles, std::uint64_t seed,
                                const std::string& out, const std::string& scene_out = "",
                                const GenerateProgress& progress = {});

// Generator bodies (one file each), used by the registry.
void emit_museum(std::uint64_t triangles, std::uint64_t seed, MeshSink& sink);
void describe_museum(Scene& scene, const Bounds& bounds);
void emit_boeing(std::uint64_t triangles, std::uint64_t seed, MeshSink& sink);
void describe_boeing(Scene& scene, const Bounds& bounds);

// Counts what passes through to `out` (generators use it to hit their budget exactly).
class BudgetSink final : public MeshSink {
 public:
  explicit BudgetSink(MeshSink& out) : out_(out) {}
  void add(const MeshPiece& p) override {
    emitted += p.triangles.size();
    out_.add(p);
  }
  std::uint64_t emitted = 0;

 private:
  MeshSink& out_;
};

}  // namespace rayline::scene
