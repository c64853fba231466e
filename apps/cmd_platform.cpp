// `rayline platform check FILE`: validate (via the loader) and summarise a DCG (Sec. 3.2):
// counts, and the uncontended Eq. 1 fetch time of one block from the nearest disk to every
// memory device (the "move data or move rays" trade-off of Sec. 6 at a glance).
#include "apps/cmd_platform.hpp"

#include <cstdio>
#include <map>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>

#include "apps/cli_common.hpp"
#include "apps/platform_path.hpp"
#include "common/error.hpp"
#include "sched/io/platform_loader.hpp"

namespace rayline::cli {

int run_platform_check(const PlatformCheckOptions& opt) {
  const Bytes block = size_flag("--block-size", opt.block_size);
  const DeviceGraph g = load_platform(resolve_platform(opt.file));
  std::map<std::string, int> mem_kinds, comp_kinds;
  for (const auto& m : g.memories) ++mem_kinds[std::string(to_string(m.kind))];
  for (const auto& c : g.computes) ++comp_kinds[std::string(to_string(c.kind))];
  std::vector<MemId> disks;
  for (std::size_t m = 0; m < g.memories.size(); ++m)
    if (g.memories[m].kind == MemoryKind::Disk) disks.push_back(static_cast<MemId>(m));
  const std::vector<Time> fetch = g.shortest_fetch_times(disks, block);
  if (opt.json) {
    nlohmann::json j;
    j["name"] = g.name;
    j["file"] = g.source_file;
    j["nodes"] = g.nodes.size();
    j["compute_devices"] = {{"total", g.computes.size()}, {"by_kind", comp_kinds}};
    j["memory_devices"] = {{"total", g.memories.size()}, {"by_kind", mem_kinds}};
    j["channels"] = g.channels.size();
    j["resources"] = g.resources.size();
    j["job_types"] = g.job_types;
    j["block_bytes"] = block;
    j["shortest_fetch_s"] = nlohmann::json::object();
    for (std::size_t m = 0; m < g.memories.size(); ++m)  // null: unreachable from every disk
      j["shortest_fetch_s"][g.memories[m].name] =
          fetch[m] == kNever ? nlohmann::json(nullptr) : nlohmann::json(fetch[m]);
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  auto kinds = [](const std::map<std::string, int>& k) {
    std::string s;
    for (const auto& [n, c] : k) s += (s.empty() ? "" : ", ") + std::to_string(c) + " " + n;
    return s;
  };
  std::printf("platform %s (%s): valid\n", g.name.c_str(), g.source_file.c_str());
  std::printf("  nodes            %zu\n", g.nodes.size());
  std::printf("  compute devices  %zu (%s)\n", g.computes.size(), kinds(comp_kinds).c_str());
  std::printf("  memory devices   %zu (%s)\n", g.memories.size(), kinds(mem_kinds).c_str());
  std::printf("  channels         %zu (on %zu contended resources)\n", g.channels.size(), g.resources.size());
  std::printf("\nshortest fetch of a %s block from any disk (Eq. 1 along the best path, no contention):\n",
              opt.block_size.c_str());
  for (std::size_t m = 0; m < g.memories.size(); ++m) {
    const std::string kind(to_string(g.memories[m].kind));
    if (fetch[m] == kNever)
      std::printf("  %-16s %-5s %12s\n", g.memories[m].name.c_str(), kind.c_str(), "unreachable");
    else
      std::printf("  %-16s %-5s %12s\n", g.memories[m].name.c_str(), kind.c_str(), format_duration(fetch[m]).c_str());
  }
  return 0;
}

}  // namespace rayline::cli
