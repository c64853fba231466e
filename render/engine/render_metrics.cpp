#include "render/engine/render_metrics.hpp"

#include "common/invocation.hpp"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <set>

#include "render/engine/renderer.hpp"
#include "sched/timeline/utilisation.hpp"

namespace rayline::engine {

using nlohmann::json;

namespace {
double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

using Intervals = std::vector<std::pair<double, double>>;
// Sorted, disjoint union of intervals.
Intervals merged(Intervals v) {
  std::sort(v.begin(), v.end());
  Intervals out;
  for (auto [a, b] : v) {
    if (b <= a) continue;
    if (!out.empty() && a <= out.back().second) out.back().second = std::max(out.back().second, b);
    else out.emplace_back(a, b);
  }
  return out;
}
double length(const Intervals& v) {
  double t = 0;
  for (auto [a, b] : v) t += b - a;
  return t;
}
// [lo, hi] minus a sorted disjoint union.
Intervals complement(const Intervals& v, double lo, double hi) {
  Intervals out;
  double at = lo;
  for (auto [a, b] : v) {
    if (b <= at) continue;
    if (a >= hi) break;
    if (a > at) out.emplace_back(at, a);
    at = std::max(at, b);
  }
  if (at < hi) out.emplace_back(at, hi);
  return out;
}
double overlap(const Intervals& x, const Intervals& y) {  // both sorted and disjoint
  double t = 0;
  for (std::size_t i = 0, j = 0; i < x.size() && j < y.size();) {
    t += std::max(0.0, std::min(x[i].second, y[j].second) - std::max(x[i].first, y[j].first));
    (x[i].second < y[j].second ? i : j) += 1;
  }
  return t;
}

// "disk channel busy >= 80 % of the time whenever the run is I/O-bound". The run
// is I/O-bound while no compute device runs an E-job: every device then waits for data the
// disk->RAM channel brings (or for nothing, at the very start and end, which the window
// [first disk T-job start, last disk T-job end] leaves out). Returns (I/O-bound seconds,
// share of them the channel spent on T-jobs). T-jobs alone undercount the channel (a
// read-ahead runs before its T-job starts), so the share is a lower bound.
std::pair<double, double> io_bound_busy(const Schedule& s) {
  const DeviceGraph& g = s.graph();
  Intervals exec, disk;
  for (ActivityId a = 0; a < ActivityId(s.activity_count()); ++a) {
    const Activity& x = s.activity(a);
    if (x.state != ActivityState::Done || x.cancelled) continue;
    if (x.kind == ActivityKind::Exec) exec.emplace_back(x.start, x.end);
    else if (g.memories[g.channels[x.channel].from].kind == MemoryKind::Disk) disk.emplace_back(x.start, x.end);
  }
  if (disk.empty()) return {0.0, 0.0};
  disk = merged(std::move(disk));
  const Intervals bound = complement(merged(std::move(exec)), disk.front().first, disk.back().second);
  const double t = length(bound);
  return {t, t > 0 ? overlap(bound, disk) / t : 0.0};
}

// The disk->RAM channel and the block store: loads, reads, how busy the disk was.
json io_json(const RenderResult& r, const Schedule& s, const std::vector<double>& lane_busy, double secs) {
  const DeviceGraph& g = s.graph();
  // Disk channel: busy share of the run (all resources behind disk→RAM channels).
  double disk_busy = 0;
  std::set<ResourceId> disk_res;
  for (const Channel& c : g.channels)
    if (g.memories[c.from].kind == MemoryKind::Disk)
      for (ResourceId x : c.resources) disk_res.insert(x);
  for (ResourceId x : disk_res) disk_busy = std::max(disk_busy, lane_busy.at(g.computes.size() + std::size_t(x)));
  // With read-ahead a block's read overlaps the previous T-job: the channel is busy for the
  // union of reads and builds (BlockStore), which the T-jobs' own time undercounts.
  disk_busy = std::max(disk_busy, r.store.channel_busy_seconds);
  const auto [io_bound_s, busy_when_io_bound] = io_bound_busy(s);
  return {{"loads", r.store.loads},
          {"loaders", r.loaders},
          {"evictions", r.store.evictions},
          {"unplanned_loads", r.store.unplanned_loads},
          {"bytes_read", r.store.bytes_read},
          {"read_seconds", r.store.read_seconds},
          {"bvh_build_seconds", r.store.build_seconds},
          {"direct_reads", r.store.direct_reads},
          {"buffered_reads", r.store.buffered_reads},
          {"mode", r.store.buffered_reads == 0 ? "O_DIRECT" : (r.store.direct_reads == 0 ? "buffered+DONTNEED" : "mixed")},
          {"read_aheads", r.store.read_aheads},
          {"recycled_arrays", r.store.recycled_arrays},
          {"wasted_read_aheads", r.store.wasted_read_aheads},
          {"disk_read_fraction", r.store.disk_read_busy_seconds / secs},
          {"disk_busy_fraction", disk_busy / secs},
          {"io_bound_seconds", io_bound_s},
          {"disk_busy_when_io_bound", busy_when_io_bound}};
}

// Cache hits and the timing model's accuracy, from the plan's activities.
void activity_json(const RenderResult& r, const Schedule& s, json& m) {
  // Cache hits: E-jobs whose SceneData was already in RAM (no T-job fetched it for them).
  std::set<JobId> fetched_for;
  std::uint64_t execs = 0;
  std::vector<double> err_exec, err_transfer;
  for (ActivityId a = 0; a < ActivityId(s.activity_count()); ++a) {
    const Activity& x = s.activity(a);
    if (x.kind == ActivityKind::Transfer) fetched_for.insert(x.job);
    else ++execs;
    if (x.state != ActivityState::Done || x.duration <= 0) continue;
    const double rel = std::fabs((x.end - x.start) - x.duration) / x.duration;
    (x.kind == ActivityKind::Exec ? err_exec : err_transfer).push_back(rel);
  }
  m["cache"] = {{"exec_jobs", execs},
                {"hits", execs - std::min<std::uint64_t>(execs, fetched_for.size())},
                {"hit_ratio", execs ? double(execs - std::min<std::uint64_t>(execs, fetched_for.size())) / double(execs) : 0.0}};
  m["jobs"] = {{"created", r.jobs}, {"merges", r.merges}, {"plan_calls", r.run.plan_calls},
               {"scheduler_seconds", r.run.scheduler_wall_seconds}};
  if (r.run.faults > 0 || r.run.retried > 0)  // docs/faults.md
    m["faults"] = {{"applied", r.run.faults}, {"activities_aborted", r.run.aborted},
                   {"jobs_queued_again", r.run.requeued}, {"failed_activities_retried", r.run.retried}};
  m["predicted_vs_actual"] = {{"exec_median_rel_error", median(err_exec)},
                              {"transfer_median_rel_error", median(err_transfer)},
                              {"exec_samples", err_exec.size()},
                              {"transfer_samples", err_transfer.size()}};
  // The loop's dispatch latency per E-job on a CPU thread (renderer.hpp, dispatch_gaps).
  std::vector<double> gaps(r.dispatch_gaps.begin(), r.dispatch_gaps.end());
  std::sort(gaps.begin(), gaps.end());
  double sum = 0;
  for (double g : gaps) sum += g;
  m["dispatch_gap_s"] = {{"mean", gaps.empty() ? 0.0 : sum / double(gaps.size())},
                         {"p50", gaps.empty() ? 0.0 : gaps[gaps.size() / 2]},
                         {"p90", gaps.empty() ? 0.0 : gaps[gaps.size() * 9 / 10]},
                         {"total", sum},
                         {"samples", gaps.size()}};
}

// Per compute device: utilisation and where its idle time went.
json devices_json(const RenderResult& r, const Schedule& s) {
  const DeviceGraph& g = s.graph();
  const Utilisation u = compute_utilisation(s, 0, r.seconds);
  json devs = json::array();
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    const DeviceTime& t = u.devices[d];
    devs.push_back({{"device", g.computes[d].name},
                    {"utilisation", t.utilisation(u.span)},
                    {"busy_s", t.busy},
                    {"setup_s", t.setup},
                    {"fetching_idle_s", t.fetching},
                    {"true_idle_s", t.idle}});
  }
  return devs;
}

// The Vulkan device: what ran there, what fell back to the CPU path and why.
json gpu_json(const RenderResult& r) {
  return {{"device", r.gpu_device},
          {"cpu_backed", r.gpu_cpu_backed},
          {"status", r.gpu_status},
          {"memory_budget_bytes", r.gpu_memory_budget},
          {"jobs", r.gpu.gpu_jobs},
          {"fallback_jobs", r.gpu.fallback_jobs},
          {"rays", r.gpu.gpu_rays},
          {"fallback_rays", r.gpu.fallback_rays},
          // rays the kernels flagged doubtful (render/vulkan/README.md, "Doubtful rays")
          // and their share of the rays the GPU traced; they ran as CPU-only jobs
          {"doubtful_rays", r.gpu.doubtful_rays},
          {"doubtful_fraction", r.gpu.gpu_rays ? double(r.gpu.doubtful_rays) / double(r.gpu.gpu_rays) : 0.0},
          {"resolve_doubtful", r.gpu_resolve_doubtful},
          {"kernel_seconds", r.gpu.kernel_seconds},
          {"block_uploads", r.gpu.block_uploads},
          {"block_evictions", r.gpu.block_evictions},
          {"upload_failures", r.gpu.upload_failures},
          {"ray_uploads", r.gpu.ray_uploads},
          {"unplanned_ray_uploads", r.gpu.unplanned_ray_uploads},
          {"block_bytes_uploaded", r.gpu.block_bytes},
          {"ray_bytes_uploaded", r.gpu.ray_bytes},
          {"bvh_build_seconds", r.gpu.build_seconds},
          {"upload_seconds", r.gpu.upload_seconds},
          {"peak_device_bytes", r.gpu.peak_device_bytes}};
}

// A distributed render (render/mpi/README.md): the LAN as measured, what crossed it, and
// per rank what it ran, loaded and sent.
json distributed_json(const RenderResult& r) {
  json d;
  d["lan"] = {{"latency_s", r.lan.latency}, {"bandwidth_bytes_per_s", r.lan.bandwidth}};
  Bytes bytes = 0;
  Time seconds = 0;
  for (const auto& [b, t] : r.lan_samples) bytes += b, seconds += t;
  d["lan_transfers"] = {{"count", r.lan_samples.size()}, {"planned_bytes", bytes}, {"seconds", seconds}};
  json ranks = json::array();
  for (const RankStats& s : r.ranks)
    ranks.push_back({{"host", s.host}, {"execs", s.execs}, {"loads", s.loads}, {"evictions", s.evictions},
                     {"bytes_read", s.bytes_read}, {"scene_blocks_in", s.scene_in}, {"scene_blocks_out", s.scene_out},
                     {"ray_queues_in", s.queues_in}, {"ray_queues_out", s.queues_out},
                     {"messages_sent", s.messages_sent}, {"bytes_sent", s.bytes_sent}, {"lost", s.lost}, {"gpu_jobs", s.gpu_jobs},
                     {"exec_traced_seconds", s.exec_traced_seconds}, {"exec_seen_seconds", s.exec_seen_seconds}});
  d["ranks"] = ranks;
  return d;
}

}  // namespace

std::string render_metrics_json(const RenderResult& r, const Schedule& s, const std::vector<double>& lane_busy) {
  json m;
  if (!invocation_command().empty())
    m["rayline"] = {{"version", invocation_version()}, {"command", invocation_command()}};
  m["scene"] = r.scene_name;
  m["resolution"] = {r.width, r.height};
  m["spp"] = r.spp;
  m["max_depth"] = r.max_depth;
  m["seed"] = r.seed;
  m["blocks"] = r.blocks;
  m["scheduler"] = r.scheduler;
  m["scheduler_parameters"] = r.scheduler_parameters;
  m["platform"] = r.platform;
  m["bvh_quality"] = r.bvh_quality;
  m["threads"] = r.threads;
  // The batching in force (docs/renderer.md): camera jobs only with one block and CPU threads.
  m["batching"] = {{"min_batch", r.min_batch},
                   {"max_batch", r.max_batch},
                   {"continue_in_cell", r.continue_in_cell},
                   {"camera_jobs", r.camera_jobs}};
  m["seconds"] = r.seconds;
  m["partition_seconds"] = r.partition_seconds;
  // Tracing throughput without the first load: in core with one block this excludes
  // reading and building the BVH, as Embree's tutorial timing does.
  m["first_exec_start_s"] = r.first_exec_start;
  m["samples_per_second_after_first_exec"] =
      r.seconds > r.first_exec_start ? double(r.camera_rays) / (r.seconds - r.first_exec_start) : 0.0;
  const double secs = r.seconds > 0 ? r.seconds : 1e-9;
  // A ray is counted once (created); `cell_visits` counts it once per cell it was tested in.
  m["rays"] = {{"cell_visits", r.counts.traced},
               {"cells_skipped", r.counts.skipped},
               {"camera", r.camera_rays},
               {"created", r.counts.created},
               {"escaped", r.counts.escaped},
               {"terminated", r.counts.terminated},
               {"occluded", r.counts.occluded},
               {"unoccluded", r.counts.unoccluded},
               {"conserved", r.counts.created == r.counts.ended()}};
  m["rays_per_second"] = double(r.counts.created) / secs;
  m["cell_visits_per_ray"] = r.counts.created ? double(r.counts.traced) / double(r.counts.created) : 0.0;
  m["samples_per_second"] = double(r.camera_rays) / secs;
  m["film_dropped_contributions"] = r.film_dropped;
  m["memory"] = {{"budget_bytes", r.memory_budget},
                 {"paths_in_flight_cap", r.path_cap},
                 {"scene_block_bytes", r.scene_block_bytes},
                 {"peak_resident_block_bytes", r.store.peak_resident_bytes},
                 {"peak_embree_bytes", r.store.peak_embree_bytes},
                 {"worst_footprint_ratio", r.store.worst_footprint_ratio},
                 {"rss_at_start_bytes", r.rss_start_bytes},
                 {"peak_rss_bytes", r.peak_rss_bytes},
                 {"overhead_bound_bytes", r.overhead_bound_bytes}};
  m["io"] = io_json(r, s, lane_busy, secs);
  activity_json(r, s, m);
  m["devices"] = devices_json(r, s);
  m["gpu"] = gpu_json(r);
  if (!r.ranks.empty()) m["distributed"] = distributed_json(r);
  return m.dump(2) + "\n";
}

}  // namespace rayline::engine
