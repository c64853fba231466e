// `rayline compare`: one `rayline simulate` run per scheduler on the same platform, workload,
// seed and duration, each in its own process (SimGrid's engine is a process-wide
// singleton), results in OUT/<scheduler>/; then a table and OUT/compare.csv, compare.json.
// A run that fails or stalls stays in the table with its status (never dropped). The runs
// write into a staging folder that replaces OUT only once every run completed (finished,
// or stalled with its results saying so; apps/run/staged_folder.hpp).
#include "apps/cmd_compare.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "apps/cli_common.hpp"
#include "apps/run/child_process.hpp"
#include "apps/run/run_options.hpp"
#include "apps/run/staged_folder.hpp"
#include "common/error.hpp"
#include "sched/policy/scheduler_factory.hpp"

namespace rayline::cli {

namespace {

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

struct Row {
  std::string scheduler, status;
  int exit_code = 0;
  double rays = 0, steady = -1, visits = -1, lan = -1, busy = 0, fetching = 0, idle = 0, sched_wall = 0, sched_share = 0, wall = 0;
  double wait_p50 = -1, wait_p95 = -1;  // E-jobs' waits in the queue (s)
  int clients = 0;        // path tracing: the clients of this run (a sweep: of its peak)
  std::string run_dir;    // the run's folder under OUT
  std::string parameters;
};

double num(const nlohmann::json& j, const char* key, double dflt) {
  return j.contains(key) && j[key].is_number() ? j[key].get<double>() : dflt;
}

Row read_row(const std::string& sched, const std::string& dir, int rc) {
  Row r;
  r.scheduler = sched;
  r.exit_code = rc;
  r.status = rc == kExitOk ? "ok" : rc == kExitFailure ? "failed/stalled" : "bad input";
  std::ifstream f(dir + "/metrics.json");
  if (!f) return r;
  nlohmann::json m;
  try {
    f >> m;
  } catch (const std::exception&) {
    return r;
  }
  r.rays = num(m, "rays_per_second", 0);
  r.lan = num(m, "lan_utilisation_mean", -1);
  if (m.contains("path_trace")) {
    r.steady = num(m["path_trace"], "steady_rays_shot_per_second", -1);
    r.visits = num(m["path_trace"], "steady_block_visits_per_second", -1);
    // A run that completed but delivered nothing is not "ok" (metrics.json says why).
    if (r.status == "ok" && m["path_trace"].contains("nothing_delivered")) r.status = "no rays ended";
  }
  double n = 0;
  for (const auto& d : m.value("devices", nlohmann::json::array())) {
    const double span = num(d, "busy_s", 0) + num(d, "setup_s", 0) + num(d, "fetching_s", 0) + num(d, "idle_s", 0);
    if (span <= 0) continue;
    r.busy += (num(d, "busy_s", 0) + num(d, "setup_s", 0)) / span;
    r.fetching += num(d, "fetching_s", 0) / span;
    r.idle += num(d, "idle_s", 0) / span;
    ++n;
  }
  if (n > 0) r.busy /= n, r.fetching /= n, r.idle /= n;
  if (m.contains("scheduler_cost")) {
    r.sched_wall = num(m["scheduler_cost"], "wall_s", 0);
    r.sched_share = num(m["scheduler_cost"], "share_of_simulated_time", 0);
  }
  if (m.contains("simulator")) r.wall = num(m["simulator"], "wall_s", 0);
  if (m.contains("queue_wait_s")) {
    r.wait_p50 = num(m["queue_wait_s"], "p50", -1);
    r.wait_p95 = num(m["queue_wait_s"], "p95", -1);
  }
  r.parameters = m.value("scheduler_parameters", "");
  return r;
}

// The --schedulers list: names the factory knows, each once (each writes OUT/<name>: a
// second run of one would overwrite the first).
std::vector<std::string> scheduler_list(const std::string& text) {
  const std::vector<std::string> scheds = split_list(text);
  if (scheds.empty()) throw InputError("--schedulers", "", "expected a list such as gmb,budge,loadanyonce");
  for (const std::string& s : scheds) {
    scheduler_flag("--schedulers", s, "");
    if (std::count(scheds.begin(), scheds.end(), s) > 1)
      throw InputError("--schedulers", "", "'" + s + "' is listed twice");
  }
  return scheds;
}

// The table on stdout, compare.csv and compare.json into `dir`; rays/s relative to gmb's.
// `out` is the folder as the user named it (OUT), which the table and the JSON show.
void report(const std::vector<Row>& rows, const std::string& out, const std::string& dir) {
  const Row* ref = nullptr;
  for (const Row& r : rows)
    if (r.scheduler == "gmb") ref = &r;
  auto metric = [](const Row& r) { return r.steady >= 0 ? r.steady : r.rays; };
  std::printf("\n%-12s %-15s %18s %7s %9s %8s %6s %9s %6s %12s %15s\n", "scheduler", "status", "throughput", "clients",
              "vs gmb", "LAN util", "busy", "fetching", "idle", "sched wall s", "wait p50/p95 s");
  std::ostringstream csv;
  csv << "scheduler,status,exit_code,rays_per_second,steady_rays_shot_per_second,lan_utilisation_mean,busy,fetching,true_idle,"
         "scheduler_wall_s,scheduler_share,sim_wall_s,scheduler_parameters,queue_wait_p50_s,queue_wait_p95_s,"
         "steady_block_visits_per_second,clients\n";
  nlohmann::json js = nlohmann::json::array();
  for (const Row& r : rows) {
    char rel[32] = "-";
    if (ref && metric(*ref) > 0 && r.status == "ok") std::snprintf(rel, sizeof rel, "%+.1f%%", 100 * (metric(r) / metric(*ref) - 1));
    char lan[32] = "-";
    if (r.lan >= 0) std::snprintf(lan, sizeof lan, "%.1f%%", 100 * r.lan);
    char wait[48] = "-";
    if (r.wait_p50 >= 0) std::snprintf(wait, sizeof wait, "%.2f/%.2f", r.wait_p50, r.wait_p95);
    std::printf("%-12s %-15s %18s %7d %9s %8s %5.1f%% %8.1f%% %5.1f%% %12.3f %15s\n", r.scheduler.c_str(), r.status.c_str(),
                format_rate(metric(r), "rays").c_str(), r.clients, rel,
                lan, 100 * r.busy, 100 * r.fetching, 100 * r.idle, r.sched_wall, wait);
    std::string params = r.parameters;
    for (char& c : params)
      if (c == '"') c = '\'';
    csv << r.scheduler << ',' << r.status << ',' << r.exit_code << ',' << r.rays << ',' << r.steady << ',' << r.lan << ','
        << r.busy << ',' << r.fetching << ',' << r.idle << ',' << r.sched_wall << ',' << r.sched_share << ',' << r.wall
        << ",\"" << params << "\"," << r.wait_p50 << ',' << r.wait_p95 << ',' << r.visits << ',' << r.clients << '\n';
    js.push_back({{"scheduler", r.scheduler}, {"status", r.status}, {"exit_code", r.exit_code},
                  {"rays_per_second", r.rays}, {"steady_rays_shot_per_second", r.steady}, {"lan_utilisation_mean", r.lan},
                  {"busy", r.busy}, {"fetching", r.fetching}, {"true_idle", r.idle}, {"scheduler_wall_s", r.sched_wall},
                  {"scheduler_share", r.sched_share}, {"sim_wall_s", r.wall}, {"scheduler_parameters", r.parameters},
                  {"queue_wait_p50_s", r.wait_p50}, {"queue_wait_p95_s", r.wait_p95},
                  {"steady_block_visits_per_second", r.visits}, {"clients", r.clients},
                  {"out", out + "/" + r.run_dir}});
  }
  for (const Row& r : rows)
    if (r.status == "no rays ended")
      std::printf("%s: no ray ended after the warm-up (why: %s/%s/metrics.json, path_trace.nothing_delivered)\n",
                  r.scheduler.c_str(), out.c_str(), r.run_dir.c_str());
  std::printf("throughput: path tracing: rays shot per second in the steady state (each ray once, the paper's unit); ray "
              "stream and job sets: rays intersected in a block per second over the whole run; results in %s/<scheduler>/, "
              "%s/compare.csv, compare.json\n",
              out.c_str(), out.c_str());
  write_file_atomic(dir + "/compare.csv", csv.str());
  write_file_atomic(dir + "/compare.json", js.dump(1) + "\n");
}

}  // namespace

int run_compare(const CompareOptions& opt) {
  const std::vector<std::string> scheds = scheduler_list(opt.schedulers);
  // --clients N1,N2,... or auto: each scheduler is swept (OUT/<scheduler>/clients-N/) and
  // compared at its own peak, as the paper compares methods (Sec. 6).
  const bool sweep = opt.sim.clients.find(',') != std::string::npos || opt.sim.clients.starts_with("auto");
  check_simulate_flags(opt.sim);
  // Each run replaces OUT/<scheduler>, and the results replace OUT: checked for the user's
  // files before the first run.
  for (const std::string& s : scheds) check_run_folder(opt.sim, opt.out + "/" + s);
  std::vector<std::string> folders;
  for (const std::string_view name : kSchedulerNames) folders.emplace_back(name);
  const auto check = [&] { return check_results_set(opt.sim, opt.out, {"compare.csv", "compare.json", "report.html"}, folders); };
  StagedFolder stage(check(), opt.out, "--out", check);
  std::vector<Row> rows;
  for (const auto& s : scheds) {
    std::printf("== %s ==\n", s.c_str());
    std::fflush(stdout);
    SimulateOptions o = opt.sim;
    o.scheduler = s;
    o.out = opt.out + "/" + s;
    o.no_progress = true;
    const std::string dir = stage.path() + "/" + s;
    int clients = 0;
    int rc = 0;
    if (sweep) {
      std::filesystem::create_directories(dir);
      rc = guarded([&] { return run_sweep_into(o, dir, clients); });
    } else {
      std::string ignored;
      rc = run_in_child([&](int) { return guarded([&] { return run_simulate_into(o, dir); }); }, ignored);
      clients = std::atoi(opt.sim.clients.c_str());
    }
    if (rc == kExitBadInput) return rc;  // the same input is bad for every scheduler
    rows.push_back(read_row(s, sweep ? dir + "/clients-" + std::to_string(clients) : dir, rc));
    rows.back().clients = clients;
    rows.back().run_dir = sweep ? s + "/clients-" + std::to_string(clients) : s;
  }
  report(rows, opt.out, stage.path());
  for (const Row& r : rows)
    if (!run_completed(stage.path() + "/" + r.run_dir)) {
      std::fprintf(stderr, "rayline: the %s run failed (exit %d); nothing is published under %s\n", r.scheduler.c_str(),
                   r.exit_code, opt.out.c_str());
      return kExitFailure;
    }
  stage.publish();
  for (const Row& r : rows)
    if (r.status != "ok" && r.status != "no rays ended") return kExitFailure;  // (that one completed)
  return kExitOk;
}

}  // namespace rayline::cli
