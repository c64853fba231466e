// Reading a run's output folder for `rayline report` (apps/report/run_files.hpp).
#include "apps/report/run_files.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "common/error.hpp"
#include "common/input_file.hpp"
#include "common/json_fields.hpp"

namespace rayline::report {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string read_text(const std::string& path, const std::string& what) {
  std::ifstream in = open_input(path, what);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The member at a dotted path ("queue_wait_s.p50"), or null when any step is missing.
const json* lookup(const json& root, const std::string& dotted) {
  const json* at = &root;
  std::size_t from = 0;
  while (true) {
    const std::size_t dot = dotted.find('.', from);
    const std::string key = dotted.substr(from, dot == std::string::npos ? std::string::npos : dot - from);
    if (!at->is_object()) return nullptr;
    const auto it = at->find(key);
    if (it == at->end()) return nullptr;
    at = &*it;
    if (dot == std::string::npos) return at;
    from = dot + 1;
  }
}

// An optional string member; InputError at its path when it is there but not a string.
std::string optional_string(const JsonField& parent, std::string_view key) {
  const auto f = parent.find(key);
  return f ? f->string() : std::string();
}

double optional_number(const JsonField& parent, std::string_view key) {
  const auto f = parent.find(key);
  return f ? f->number() : 0.0;
}

// The header facts: a label, a dotted metrics path and a unit (see Fact).
struct FactSpec {
  const char* label;
  const char* path;
  const char* unit;
};

constexpr FactSpec kSimulateFacts[] = {
    {"rays/s over the run", "rays_per_second", "rays/s"},
    {"steady rays shot/s", "path_trace.steady_rays_shot_per_second", "rays/s"},
    {"simulated time", "simulated_s", "s"},
    {"makespan (actual)", "makespan_s.actual", "s"},
    {"makespan (planned)", "makespan_s.planned", "s"},
    {"E-jobs done", "activities.e_jobs_done", ""},
    {"T-jobs done", "activities.t_jobs_done", ""},
    {"LAN utilisation (mean)", "lan_utilisation_mean", "%"},
    {"queue wait p50", "queue_wait_s.p50", "s"},
    {"queue wait p95", "queue_wait_s.p95", "s"},
    {"frames delivered", "path_trace.frames.delivered", ""},
    {"scheduler wall time", "scheduler_cost.wall_s", "s"},
    {"start", "start", ""},
    {"transfer order", "transfer_order", ""},
    {"seed", "seed", ""},
    {"stalled", "stalled", ""},
};

constexpr FactSpec kRenderFacts[] = {
    {"wall time", "seconds", "s"},
    {"rays/s", "rays_per_second", "rays/s"},
    {"samples/s", "samples_per_second", "samples/s"},
    {"resolution", "resolution", ""},
    {"samples per pixel", "spp", ""},
    {"threads", "threads", ""},
    {"blocks", "blocks", ""},
    {"bytes read", "io.bytes_read", "B"},
    {"peak resident set", "memory.peak_rss_bytes", "B"},
    {"cache hit ratio", "cache.hit_ratio", "%"},
    {"seed", "seed", ""},
};

std::optional<Fact> fact_of(const json& root, const FactSpec& spec) {
  const json* v = lookup(root, spec.path);
  if (!v) return std::nullopt;
  Fact f{spec.label, std::nullopt, spec.unit, ""};
  if (v->is_number()) {
    f.value = v->get<double>();
  } else if (v->is_string()) {
    f.text = v->get<std::string>();
  } else if (v->is_boolean()) {
    f.text = v->get<bool>() ? "yes" : "no";
  } else if (v->is_array() && v->size() == 2 && (*v)[0].is_number() && (*v)[1].is_number()) {
    f.text = std::to_string((*v)[0].get<long long>()) + " x " + std::to_string((*v)[1].get<long long>());
  } else {
    return std::nullopt;
  }
  return f;
}

// "W.cpu1" -> "cpu": the device's name after the node, without its number.
std::string kind_from_name(const std::string& name) {
  const std::size_t dot = name.rfind('.');
  std::string k = dot == std::string::npos ? name : name.substr(dot + 1);
  while (!k.empty() && std::isdigit(static_cast<unsigned char>(k.back()))) k.pop_back();
  return k;
}

// devices[]: simulate names busy_s, setup_s, fetching_s, idle_s; render names device,
// fetching_idle_s, true_idle_s.
std::vector<DeviceTime> read_devices(const JsonField& root, bool render) {
  std::vector<DeviceTime> out;
  const auto devices = root.find("devices");
  if (!devices) return out;
  for (const JsonField& d : devices->elements()) {
    d.object();
    DeviceTime t;
    t.name = d.at(render ? "device" : "name").string();
    t.kind = render ? kind_from_name(t.name) : optional_string(d, "kind");
    t.busy_s = d.at("busy_s").number();
    t.setup_s = optional_number(d, "setup_s");
    t.fetching_s = d.at(render ? "fetching_idle_s" : "fetching_s").number();
    t.idle_s = d.at(render ? "true_idle_s" : "idle_s").number();
    out.push_back(std::move(t));
  }
  return out;
}

std::vector<ChannelUse> read_resources(const JsonField& root) {
  std::vector<ChannelUse> out;
  const auto resources = root.find("resources");
  if (!resources) return out;
  for (const JsonField& r : resources->elements()) {
    r.object();
    ChannelUse c;
    c.name = r.at("resource").string();
    c.utilisation = r.at("utilisation").number();
    c.bytes = optional_number(r, "bytes");
    if (const auto lan = r.find("lan")) {
      if (!lan->json().is_boolean()) lan->fail("expected true or false");
      c.lan = lan->json().get<bool>();
    }
    out.push_back(std::move(c));
  }
  return out;
}

// A number cell of jobs.csv; empty is "not reached".
std::optional<double> number_cell(const std::string& text, const std::string& file, const std::string& field) {
  if (text.empty()) return std::nullopt;
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(v))
    throw InputError(file, field, "expected a number, got '" + text + "'");
  return v;
}

// Where each named column of jobs.csv is; InputError naming the first one missing.
std::map<std::string, std::size_t> column_index(const std::vector<std::string>& header, const std::string& file,
                                                std::initializer_list<const char*> required) {
  std::map<std::string, std::size_t> at;
  for (std::size_t i = 0; i < header.size(); ++i) at.emplace(header[i], i);
  for (const char* name : required)
    if (!at.count(name)) throw InputError(file, "header", std::string("missing column '") + name + "'");
  return at;
}

}  // namespace

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> cells(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
      cells.back() += '"';
      ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      cells.emplace_back();
    } else if (c != '\r' || quoted) {
      cells.back() += c;
    }
  }
  return cells;
}

std::string CompareTable::cell(std::size_t row, const std::string& name) const {
  const auto it = std::find(header.begin(), header.end(), name);
  if (it == header.end() || row >= rows.size()) return {};
  const auto col = static_cast<std::size_t>(it - header.begin());
  return col < rows[row].size() ? rows[row][col] : std::string();
}

RunData read_metrics_file(const std::string& path, bool render) {
  const JsonInput input(path);
  const json doc = input.parse(read_text(path, "metrics file"));
  const JsonField root = input.field(doc, "");
  root.object();
  RunData run;
  run.metrics_file = path;
  run.render = render;
  if (const auto id = root.find("rayline")) {
    id->object();
    run.command = optional_string(*id, "command");
    run.version = optional_string(*id, "version");
  }
  run.scheduler = optional_string(root, "scheduler");
  run.platform = optional_string(root, "platform");
  run.workload = optional_string(root, render ? "scene" : "workload");
  run.run_seconds = optional_number(root, render ? "seconds" : "simulated_s");
  if (const auto series = root.find("rays_per_second_series"))
    for (const JsonField& v : series->elements()) run.rays_per_second_series.push_back(v.number());
  run.devices = read_devices(root, render);
  run.channels = read_resources(root);
  for (const FactSpec& spec : render ? std::vector<FactSpec>(std::begin(kRenderFacts), std::end(kRenderFacts))
                                     : std::vector<FactSpec>(std::begin(kSimulateFacts), std::end(kSimulateFacts)))
    if (auto f = fact_of(doc, spec)) run.facts.push_back(std::move(*f));
  return run;
}

std::vector<Activity> read_jobs_csv(const std::string& path) {
  std::ifstream in = open_input(path, "jobs CSV");
  std::string line;
  if (!std::getline(in, line)) throw InputError(path, "header", "empty file (expected the jobs.csv header)");
  const std::vector<std::string> header = split_csv_line(line);
  const auto col = column_index(header, path,
                                {"kind", "job", "type", "device_or_channel", "block", "bytes", "planned_start",
                                 "planned_end", "actual_start", "actual_end", "state"});
  const auto created = col.find("created");
  std::vector<Activity> out;
  for (std::size_t n = 2; std::getline(in, line); ++n) {
    if (line.empty() || line == "\r") continue;
    const std::vector<std::string> c = split_csv_line(line);
    const std::string where = "line " + std::to_string(n);
    if (c.size() != header.size())
      throw InputError(path, where, std::to_string(c.size()) + " cells, the header has " + std::to_string(header.size()));
    const auto text = [&](const char* name) { return c[col.at(name)]; };
    const auto number = [&](const char* name) { return number_cell(text(name), path, where + ": " + name); };
    Activity a;
    const std::string kind = text("kind");
    if (kind != "E" && kind != "T") throw InputError(path, where + ": kind", "expected E or T, got '" + kind + "'");
    a.kind = kind[0];
    a.job = text("job");
    a.type = text("type");
    a.where = text("device_or_channel");
    a.block = text("block");
    a.state = text("state");
    a.bytes = number("bytes").value_or(0.0);
    a.planned_start = number("planned_start").value_or(0.0);
    a.planned_end = number("planned_end").value_or(a.planned_start);
    a.actual_start = number("actual_start");
    a.actual_end = number("actual_end");
    if (created != col.end()) a.created = number_cell(c[created->second], path, where + ": created");
    out.push_back(std::move(a));
  }
  return out;
}

CompareTable read_compare_csv(const std::string& path) {
  std::ifstream in = open_input(path, "compare CSV");
  CompareTable t;
  t.file = path;
  std::string line;
  if (!std::getline(in, line)) throw InputError(path, "header", "empty file (expected the compare.csv header)");
  t.header = split_csv_line(line);
  column_index(t.header, path, {"scheduler"});
  for (std::size_t n = 2; std::getline(in, line); ++n) {
    if (line.empty() || line == "\r") continue;
    t.rows.push_back(split_csv_line(line));
    if (t.rows.back().size() != t.header.size())
      throw InputError(path, "line " + std::to_string(n),
                       std::to_string(t.rows.back().size()) + " cells, the header has " + std::to_string(t.header.size()));
  }
  return t;
}

namespace {

// A simulate folder: metrics.json, and jobs.csv when it is there.
RunData read_simulate_run(const fs::path& dir, std::string label) {
  RunData run = read_metrics_file((dir / "metrics.json").string(), false);
  run.label = std::move(label);
  std::error_code ec;
  if (fs::is_regular_file(dir / "jobs.csv", ec)) {
    run.jobs_file = (dir / "jobs.csv").string();
    run.activities = read_jobs_csv(run.jobs_file);
  }
  return run;
}

// A render's outputs IMAGE.metrics.json, IMAGE.jobs.csv, IMAGE.png, found by their stem.
RunData read_render_run(const fs::path& dir, const std::string& stem) {
  RunData run = read_metrics_file((dir / (stem + ".metrics.json")).string(), true);
  run.label = stem;
  std::error_code ec;
  if (fs::is_regular_file(dir / (stem + ".jobs.csv"), ec)) {
    run.jobs_file = (dir / (stem + ".jobs.csv")).string();
    run.activities = read_jobs_csv(run.jobs_file);
  }
  if (fs::is_regular_file(dir / (stem + ".png"), ec)) run.png = read_text((dir / (stem + ".png")).string(), "PNG image");
  return run;
}

// The stems of IMAGE.metrics.json files in `dir`, sorted.
std::vector<std::string> render_stems(const fs::path& dir) {
  static const std::string kSuffix = ".metrics.json";
  std::vector<std::string> stems;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.size() > kSuffix.size() && name.ends_with(kSuffix) && e.is_regular_file(ec))
      stems.push_back(name.substr(0, name.size() - kSuffix.size()));
  }
  std::sort(stems.begin(), stems.end());
  return stems;
}

RunFolder read_compare_folder(const fs::path& dir) {
  RunFolder f;
  f.kind = RunFolder::Kind::compare;
  f.compare = read_compare_csv((dir / "compare.csv").string());
  for (std::size_t r = 0; r < f.compare->rows.size(); ++r) {
    const std::string name = f.compare->cell(r, "scheduler");
    if (name.empty() || name == "." || name == ".." || name.find('/') != std::string::npos)
      throw InputError(f.compare->file, "line " + std::to_string(r + 2) + ": scheduler",
                       "'" + name + "' is not a scheduler's folder name");
    std::error_code ec;
    if (fs::is_regular_file(dir / name / "metrics.json", ec)) f.runs.push_back(read_simulate_run(dir / name, name));
  }
  return f;
}

// The clients-N folders holding a metrics.json, by client count.
std::vector<std::pair<long, std::string>> sweep_points(const fs::path& dir) {
  static const std::string kPrefix = "clients-";
  std::vector<std::pair<long, std::string>> points;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (!name.starts_with(kPrefix) || name.size() == kPrefix.size() || name.size() > kPrefix.size() + 9) continue;
    if (!std::all_of(name.begin() + kPrefix.size(), name.end(), [](char c) { return c >= '0' && c <= '9'; })) continue;
    if (fs::is_regular_file(e.path() / "metrics.json", ec)) points.emplace_back(std::stol(name.substr(kPrefix.size())), name);
  }
  std::sort(points.begin(), points.end());
  return points;
}

}  // namespace

RunFolder read_run_folder(const std::string& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) throw InputError(dir, "", "no such folder (expected a run's output folder)");
  if (!fs::is_directory(dir, ec))
    throw InputError(dir, "", "is a file, not a folder (give the folder a run wrote its outputs into)");
  const fs::path d(dir);
  if (fs::is_regular_file(d / "compare.csv", ec)) {
    RunFolder f = read_compare_folder(d);
    f.dir = dir;
    return f;
  }
  RunFolder f;
  f.dir = dir;
  if (fs::exists(d / "metrics.json", ec)) {
    f.runs.push_back(read_simulate_run(d, ""));
    return f;
  }
  const std::vector<std::string> stems = render_stems(d);
  if (stems.empty()) {
    const auto points = sweep_points(d);
    if (points.empty())
      throw InputError(dir, "",
                       "not a run folder: it holds no metrics.json (rayline simulate), compare.csv (rayline compare), "
                       "clients-N/metrics.json (a client sweep) or IMAGE.metrics.json (rayline render)");
    f.kind = RunFolder::Kind::sweep;
    for (const auto& [n, name] : points) f.runs.push_back(read_simulate_run(d / name, name));
    return f;
  }
  f.kind = RunFolder::Kind::render;
  for (const std::string& stem : stems) f.runs.push_back(read_render_run(d, stem));
  return f;
}

}  // namespace rayline::report
