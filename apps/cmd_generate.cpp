// `rayline generate`: runs a generator into a streaming PLY writer and reports the
// throughput (triangles per second) and the files written.
#include "apps/cmd_generate.hpp"

#include <algorithm>
#include <chrono>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "apps/cli_common.hpp"
#include "render/scene/assets.hpp"
#include "render/scene/generators.hpp"
#include "common/error.hpp"
#include "common/progress_line.hpp"

namespace rayline::cli {

std::uint64_t parse_count(const std::string& text, const std::string& field) {
  if (text.empty()) throw InputError(field, "", "empty count");
  std::size_t pos = 0;
  double v = 0;
  try {
    v = std::stod(text, &pos);
  } catch (const std::exception&) {
    throw InputError(field, "", "not a count: '" + text + "' (e.g. 250000, 10K, 100M, 1G)");
  }
  const std::string suffix = text.substr(pos);
  double mul = 1;
  if (suffix == "K" || suffix == "k") mul = 1e3;
  else if (suffix == "M" || suffix == "m") mul = 1e6;
  else if (suffix == "G" || suffix == "g") mul = 1e9;
  else if (!suffix.empty()) throw InputError(field, "", "unknown suffix '" + suffix + "' in '" + text + "' (K, M or G)");
  const double n = std::round(v * mul);
  if (!(n >= 1) || n > 4e9) throw InputError(field, "", "'" + text + "' out of range [1, 4G]");
  return static_cast<std::uint64_t>(n);
}

int run_generate(const GenerateOptions& opt) {
  using namespace rayline::scene;
  if (opt.list) {
    for (const auto& g : all_generators())
      std::printf("%-15s default %llu, min %llu triangles: %s\n", g.name.c_str(),
                  static_cast<unsigned long long>(g.default_triangles),
                  static_cast<unsigned long long>(g.min_triangles), g.description.c_str());
    return 0;
  }
  if (opt.name.empty()) throw InputError("generate", "NAME", "missing generator name (known: " + generator_names() + ")");
  const GeneratorInfo* g = find_generator(opt.name);
  if (!g) throw InputError("generate", "NAME", "unknown generator '" + opt.name + "' (known: " + generator_names() + ")");
  if (opt.out.empty()) throw InputError("generate", "--out", "missing output path");
  const std::uint64_t n = opt.triangles.empty() ? g->default_triangles : parse_count(opt.triangles, "--triangles");
  if (n < g->min_triangles)
    throw InputError("--triangles", "", opt.name + " needs at least " + std::to_string(g->min_triangles));
  check_output_file(opt.out, "--out", "out/museum.ply");
  std::string ext = std::filesystem::path(opt.out).extension().string();
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  if (ext != ".ply")  // (a mesh is read back by its extension: PLY bytes in x.obj would not load)
    throw InputError(opt.out, "--out", "the mesh is written as binary PLY: use a name ending in .ply");
  // The companion scene (next to the mesh unless --scene-out names it, none for "-") and the
  // mesh may not replace each other or an asset file the generators read.
  const std::string scene_out = opt.scene_out == "-" ? std::string()
                                : opt.scene_out.empty()
                                    ? std::filesystem::path(opt.out).replace_extension(".json").string()
                                    : opt.scene_out;
  std::vector<NamedPath> assets;
  for (const std::vector<std::string>& list : {scene::scan_asset_files(), scene::cad_asset_files()})
    for (const std::string& f : list) assets.push_back({"the generators (an asset file)", f});
  check_distinct({{"--out", opt.out}, {opt.scene_out.empty() ? "--out (its scene)" : "--scene-out", scene_out}}, assets);
  if (!scene_out.empty()) check_output_file(scene_out, opt.scene_out.empty() ? "--out" : "--scene-out", "out/museum.json");
  std::error_code ec;

  const auto t0 = std::chrono::steady_clock::now();
  // Large counts run for minutes (about 4 M triangles/s and 20-50 bytes each): a progress
  // line on stderr, as `partition` has.
  ProgressLine line(ProgressLine::for_stderr(opt.quiet));
  GenerateProgress progress;
  if (line.mode() != ProgressLine::Mode::Off)
    progress = [&line](std::uint64_t done, std::uint64_t total) {
      if (line.due())
        line.print("generate", "%5.1f %% of %.1f M triangles", 100.0 * double(done) / double(std::max<std::uint64_t>(total, 1)),
                   double(total) / 1e6);
    };
  const GenerateResult r = generate_to_file(opt.name, n, opt.seed, opt.out, opt.scene_out, progress);
  line.done();
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto bytes = std::filesystem::file_size(opt.out, ec);
  if (!opt.quiet) {
    std::printf("generated %s: %llu triangles, %llu vertices, seed %llu\n", opt.name.c_str(),
                static_cast<unsigned long long>(r.triangles), static_cast<unsigned long long>(r.vertices),
                static_cast<unsigned long long>(opt.seed));
    std::printf("bounds [%g %g %g] .. [%g %g %g]\n", r.bounds.lo.x, r.bounds.lo.y, r.bounds.lo.z, r.bounds.hi.x,
                r.bounds.hi.y, r.bounds.hi.z);
    std::printf("mesh  %s (%s)\n", r.mesh_path.c_str(), format_size(double(bytes)).c_str());
    if (!r.scene_path.empty()) std::printf("scene %s\n", r.scene_path.c_str());
  }
  std::printf("time %s, %s\n", format_duration(s).c_str(),
              format_rate(double(r.triangles) / std::max(s, 1e-9), "triangles").c_str());
  return 0;
}

}  // namespace rayline::cli
