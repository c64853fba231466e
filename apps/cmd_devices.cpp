#include "apps/cmd_devices.hpp"

#include <unistd.h>

#include <cstdio>
#include <nlohmann/json.hpp>
#include <thread>

#include "apps/cli_common.hpp"
#include "render/engine/gpu_select.hpp"
#include "render/engine/workstation.hpp"
#include "sched/core/data_block.hpp"

namespace rayline::cli {

using nlohmann::json;

namespace {

// Eq. 2 coefficients as "setup, rays/s" (64-byte ray records).
json timing_of(const DeviceGraph& g, DeviceId d) {
  json t = json::object();
  for (JobTypeId j = 0; j < JobTypeId(g.job_types.size()); ++j) {
    if (!g.timing.supports(d, j)) continue;
    const ExecCoefficients& c = g.timing.at(d, j);
    const double rate = c.rate[int(g.job_types[j] == "ShadowIntersect" ? DataKind::ShadowRayQueue : DataKind::RayQueue)];
    t[g.job_types[j]] = {{"setup_s", c.setup}, {"seconds_per_byte", rate}, {"rays_per_second", rate > 0 ? 1.0 / (64 * rate) : 0.0}};
  }
  return t;
}

}  // namespace

int run_devices(const DevicesCliOptions& opt) {
  // The sizes first: a bad flag is reported before the devices are opened.
  const Bytes ram = opt.memory_budget.empty() ? Bytes(::sysconf(_SC_PHYS_PAGES)) * Bytes(::sysconf(_SC_PAGESIZE))
                                              : size_flag("--memory-budget", opt.memory_budget);
  const Bytes gpu_budget = opt.gpu_memory_budget.empty() ? 0 : size_flag("--gpu-memory-budget", opt.gpu_memory_budget);
  json out;
  std::string why;
  const auto vk = gpu::list_gpu_devices(&why);
  out["vulkan"] = json::array();
  for (const auto& d : vk)
    out["vulkan"].push_back({{"index", d.index},
                             {"name", d.name},
                             {"type", d.type},
                             {"cpu_backed", d.cpu_backed},
                             {"device_local_bytes", d.device_local_bytes},
                             {"api_version", d.api_version},
                             {"driver", d.driver}});
  if (vk.empty()) out["vulkan_status"] = why;

  std::string status;
  auto ctx = engine::select_gpu(opt.gpu, status);
  engine::WorkstationModel m = engine::workstation_model(opt.platform);
  const bool defaults = opt.platform.empty() || opt.platform == "auto";
  const std::string source =
      defaults ? std::string("defaults (uncalibrated; `rayline calibrate` measures this machine)") : opt.platform;
  m.threads = opt.threads > 0 ? opt.threads : std::max(1, int(std::thread::hardware_concurrency()));
  m.ram_capacity = ram;
  engine::set_gpu(m, ctx ? engine::gpu_memory_budget(ctx->info(), gpu_budget) : 0);
  const DeviceGraph g = engine::make_workstation(m, opt.platform);
  out["gpu"] = {{"selector", opt.gpu}, {"status", status}, {"device", ctx ? ctx->info().name : ""},
                {"cpu_backed", ctx ? ctx->info().cpu_backed : false}};
  out["timing_source"] = source;
  out["memories"] = json::array();
  for (const MemoryDevice& md : g.memories)
    out["memories"].push_back({{"name", md.name}, {"kind", std::string(to_string(md.kind))}, {"capacity_bytes", md.capacity}});
  out["computes"] = json::array();
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    const ComputeDevice& c = g.computes[d];
    json e = {{"name", c.name}, {"kind", std::string(to_string(c.kind))}, {"memory", g.memories[c.memory].name},
              {"timing", timing_of(g, DeviceId(d))}};
    if (c.kind == ComputeKind::Gpu && ctx) e["vulkan_device"] = ctx->info().name, e["cpu_backed"] = ctx->info().cpu_backed;
    out["computes"].push_back(std::move(e));
  }
  out["channels"] = json::array();
  for (const Channel& c : g.channels)
    out["channels"].push_back({{"name", c.name}, {"kind", c.kind}, {"from", g.memories[c.from].name},
                               {"to", g.memories[c.to].name}, {"latency_s", c.latency}, {"bandwidth_bytes_per_s", c.bandwidth}});
  if (opt.json) {
    std::printf("%s\n", out.dump(2).c_str());
    return kExitOk;
  }
  std::printf("Vulkan devices:\n");
  if (vk.empty()) std::printf("  none (%s)\n", why.c_str());
  for (const auto& d : vk)
    std::printf("  %d  %-40s %-10s %s  %s  Vulkan %s  %s\n", d.index, d.name.c_str(), d.type.c_str(),
                d.cpu_backed ? "CPU-backed" : "GPU       ", format_size(double(d.device_local_bytes)).c_str(),
                d.api_version.c_str(), d.driver.c_str());
  std::printf("\n--gpu %s: %s\n", opt.gpu.c_str(), status.c_str());
  std::printf("\nWorkstation the renderer drives (timing: %s):\n", source.c_str());
  std::printf("  memory devices:\n");
  for (const MemoryDevice& md : g.memories)
    std::printf("    %-12s %-5s capacity %s\n", md.name.c_str(), std::string(to_string(md.kind)).c_str(),
                format_size(double(md.capacity)).c_str());
  std::printf("  compute devices (Eq. 2: setup + rate per 64-byte ray):\n");
  for (std::size_t d = 0; d < g.computes.size(); ++d) {
    const ComputeDevice& c = g.computes[d];
    // Identical CPU threads: print the first and the count.
    if (c.kind == ComputeKind::Cpu && d > 0 && g.computes[d - 1].kind == ComputeKind::Cpu) continue;
    std::size_t n = 1;
    while (c.kind == ComputeKind::Cpu && d + n < g.computes.size() && g.computes[d + n].kind == ComputeKind::Cpu) ++n;
    std::string name = c.name + (n > 1 ? " (x" + std::to_string(n) + ")" : "");
    if (c.kind == ComputeKind::Gpu && ctx) name += " = '" + ctx->info().name + "'" + (ctx->info().cpu_backed ? " (CPU-backed)" : "");
    std::printf("    %s on %s\n", name.c_str(), g.memories[c.memory].name.c_str());
    const json timing = timing_of(g, DeviceId(d));
    for (auto it = timing.begin(); it != timing.end(); ++it)
      std::printf("      %-16s setup %10s, %16s\n", it.key().c_str(),
                  format_duration(it.value()["setup_s"].get<double>()).c_str(),
                  format_rate(it.value()["rays_per_second"].get<double>(), "rays").c_str());
  }
  std::printf("  channels (Eq. 1: latency + bytes / bandwidth):\n");
  for (const Channel& c : g.channels)
    std::printf("    %-14s %s -> %s  latency %10s, %11s\n", c.name.c_str(), g.memories[c.from].name.c_str(),
                g.memories[c.to].name.c_str(), format_duration(c.latency).c_str(), format_bandwidth(c.bandwidth).c_str());
  return kExitOk;
}

}  // namespace rayline::cli
