#include "workload/twin_file.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "common/input_file.hpp"
#include "common/json_fields.hpp"

namespace rayline {

using json = nlohmann::json;

namespace {
constexpr const char* kFormat = "rayline-twin 1";
}

std::string TwinSpec::rays_path(const std::string& twin_file) const {
  return (std::filesystem::path(twin_file).parent_path() / rays).string();
}

std::string twin_json(const TwinSpec& t) {
  json j;
  j["format"] = kFormat;
  j["scene"] = t.scene;
  j["width"] = t.width;
  j["height"] = t.height;
  j["spp"] = t.spp;
  j["max_depth"] = t.max_depth;
  j["seed"] = t.seed;
  j["scheduler"] = t.scheduler;
  j["horizon_s"] = t.horizon;
  j["batching"] = {{"path_cap", t.path_cap},
                   {"min_batch", t.min_batch},
                   {"max_batch", t.max_batch},
                   {"continue_in_cell", t.continue_in_cell},
                   {"camera_jobs", t.camera_jobs}};
  j["memory_budget_bytes"] = t.memory_budget;
  j["blocks"] = t.blocks;
  j["rays"] = t.rays;
  j["platform"] = json::parse(t.platform_json);
  if (!t.fitted_platform_json.empty()) j["fitted_platform"] = json::parse(t.fitted_platform_json);
  j["recorded_run"] = {{"seconds", t.recorded_seconds},
                       {"loads", t.recorded_loads},
                       {"jobs", t.recorded_jobs},
                       {"traced", t.recorded_traced}};
  return j.dump(2) + "\n";
}

TwinSpec load_twin(const std::string& path) {
  std::ifstream in = open_input(path, "twin file");
  std::ostringstream ss;
  ss << in.rdbuf();
  const JsonInput input(path);
  const json doc = input.parse(ss.str());
  const JsonField root = input.field(doc, "");
  root.object();
  root.only_keys({"format", "scene", "width", "height", "spp", "max_depth", "seed", "scheduler", "horizon_s", "batching",
                  "memory_budget_bytes", "blocks", "rays", "platform", "fitted_platform", "recorded_run"});
  if (root.at("format").string() != kFormat)
    root.fail_at("format", std::string("expected \"") + kFormat + "\" (written by rayline render --record-twin)");
  TwinSpec t;
  t.scene = root.at("scene").string();
  const auto u32 = [](const JsonField& f, std::int64_t lo) {
    return static_cast<std::uint32_t>(f.integer(lo, 0xFFFFFFFFll));
  };
  t.width = u32(root.at("width"), 1);
  t.height = u32(root.at("height"), 1);
  t.spp = u32(root.at("spp"), 1);
  t.max_depth = u32(root.at("max_depth"), 1);
  t.seed = root.at("seed").unsigned_integer();
  t.scheduler = root.at("scheduler").non_empty_string();
  t.horizon = root.at("horizon_s").number();
  if (!(t.horizon > 0)) root.fail_at("horizon_s", "must be more than 0");
  const JsonField b = root.at("batching");
  b.object();
  b.only_keys({"path_cap", "min_batch", "max_batch", "continue_in_cell", "camera_jobs"});
  t.path_cap = u32(b.at("path_cap"), 1);
  t.min_batch = u32(b.at("min_batch"), 1);
  t.max_batch = u32(b.at("max_batch"), 1);
  if (t.max_batch < t.min_batch) b.fail_at("max_batch", "must be at least min_batch");
  if (b.has("continue_in_cell")) t.continue_in_cell = b.at("continue_in_cell").boolean();
  if (b.has("camera_jobs")) t.camera_jobs = b.at("camera_jobs").boolean();
  t.memory_budget = root.at("memory_budget_bytes").unsigned_integer();
  for (const JsonField& e : root.at("blocks").elements()) {
    const std::uint64_t v = e.unsigned_integer();
    if (v == 0) e.fail("a block has at least 1 byte");
    t.blocks.push_back(v);
  }
  if (t.blocks.empty()) root.fail_at("blocks", "expected at least one block");
  t.rays = root.at("rays").non_empty_string();
  root.at("platform").object();
  t.platform_json = root.at("platform").json().dump();
  if (const auto f = root.find("fitted_platform")) {
    f->object();
    t.fitted_platform_json = f->json().dump();
  }
  if (const auto r = root.find("recorded_run")) {
    r->object();
    r->only_keys({"seconds", "loads", "jobs", "traced"});
    t.recorded_seconds = r->at("seconds").number();
    t.recorded_loads = r->at("loads").unsigned_integer();
    t.recorded_jobs = r->at("jobs").unsigned_integer();
    t.recorded_traced = r->at("traced").unsigned_integer();
  }
  return t;
}

}  // namespace rayline
