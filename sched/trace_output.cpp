#include "sched/trace_output.hpp"

#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

namespace rayline {

std::string chrome_trace_json(const Schedule& s, bool include_actual) {
  using nlohmann::json;
  const DeviceGraph& g = s.graph();
  const JobPool& pool = s.pool();
  json events = json::array();
  const int pid_channels = static_cast<int>(g.nodes.size());
  auto meta = [&](int pid, int tid, const std::string& what, const std::string& name) {
    events.push_back({{"ph", "M"}, {"pid", pid}, {"tid", tid}, {"name", what}, {"args", {{"name", name}}}});
  };
  for (std::size_t n = 0; n < g.nodes.size(); ++n) meta(static_cast<int>(n), 0, "process_name", g.nodes[n].name + " (compute)");
  meta(pid_channels, 0, "process_name", "channels");
  for (std::size_t d = 0; d < g.computes.size(); ++d)
    meta(std::max(0, g.computes[d].node), static_cast<int>(d), "thread_name", g.computes[d].name);
  for (std::size_t r = 0; r < g.resources.size(); ++r) meta(pid_channels, static_cast<int>(r), "thread_name", g.resources[r].name);
  auto emit = [&](const Activity& a, ActivityId id, bool actual) {
    const double ts = (actual ? a.start : a.planned_start) * 1e6;
    const double dur = ((actual ? a.end : a.planned_end) - (actual ? a.start : a.planned_start)) * 1e6;
    const std::string cat = std::string(a.kind == ActivityKind::Exec ? "E-job" : "T-job") + (actual ? ",actual" : ",planned");
    json args = {{"activity", id}};
    if (a.job != kNone) args["job"] = pool.job(a.job).name;
    if (a.kind == ActivityKind::Exec) {
      args["type"] = g.job_types[pool.job(a.job).type];
      args["setup_us"] = a.setup * 1e6;
      events.push_back({{"ph", "X"}, {"name", pool.job(a.job).name}, {"cat", cat}, {"ts", ts}, {"dur", dur},
                        {"pid", std::max(0, g.computes[a.device].node)}, {"tid", a.device}, {"args", args}});
    } else {
      args["block"] = pool.block(a.block).name;
      args["bytes"] = a.bytes;
      args["channel"] = g.channels[a.channel].name;
      args["move"] = a.move;
      for (ResourceId r : g.channels[a.channel].resources)
        events.push_back({{"ph", "X"}, {"name", pool.block(a.block).name}, {"cat", cat}, {"ts", ts}, {"dur", dur},
                          {"pid", pid_channels}, {"tid", r}, {"args", args}});
    }
  };
  for (ActivityId id = 0; id < static_cast<ActivityId>(s.activity_count()); ++id) {
    const Activity& a = s.activity(id);
    if (a.cancelled) continue;  // withdrawn before it ran: nothing to show (jobs.csv lists it)
    emit(a, id, false);
    if (include_actual && a.state == ActivityState::Done) emit(a, id, true);
  }
  json root = {{"traceEvents", events}, {"displayTimeUnit", "ms"}, {"otherData", {{"platform", g.name}}}};
  return root.dump() + "\n";
}

std::string jobs_csv(const Schedule& s) {
  const DeviceGraph& g = s.graph();
  const JobPool& pool = s.pool();
  std::ostringstream out;
  out << "activity,kind,job,type,device_or_channel,block,bytes,planned_start,planned_end,actual_start,actual_end,state\n";
  char buf[256];
  for (ActivityId id = 0; id < static_cast<ActivityId>(s.activity_count()); ++id) {
    const Activity& a = s.activity(id);
    const bool done = a.state == ActivityState::Done;
    Bytes bytes = a.bytes;
    if (a.kind == ActivityKind::Exec)
      for (BlockId b : pool.job(a.job).inputs) bytes += pool.block(b).bytes;
    out << id << ',' << (a.kind == ActivityKind::Exec ? "E" : "T") << ','
        << (a.job == kNone ? std::string() : pool.job(a.job).name) << ','
        << (a.kind == ActivityKind::Exec ? g.job_types[pool.job(a.job).type] : std::string("transfer")) << ','
        << (a.kind == ActivityKind::Exec ? g.computes[a.device].name : g.channels[a.channel].name) << ','
        << (a.block == kNone ? std::string() : pool.block(a.block).name) << ',' << bytes << ',';
    std::snprintf(buf, sizeof buf, "%.9f,%.9f,", a.planned_start, a.planned_end);
    out << buf;
    if (done) {
      std::snprintf(buf, sizeof buf, "%.9f,%.9f,", a.start, a.end);
      out << buf;
    } else {
      out << ",,";
    }
    out << (a.cancelled ? "cancelled" : done ? "done" : "planned") << '\n';
  }
  return out.str();
}

}  // namespace rayline
