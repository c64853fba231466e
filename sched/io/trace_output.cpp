#include "sched/io/trace_output.hpp"

#include <algorithm>
#include <charconv>
#include <cstdio>
#include <sstream>
#include <string_view>
#include <system_error>
#include <vector>

namespace rayline {

namespace {

// A JSON writer for the trace's flat events. The trace of a long path-tracing run holds
// ~10^6 events; building each as an nlohmann::json object (a std::map per event) took a
// quarter of such a run, so events are written directly. Strings are escaped per RFC 8259
// Sec. 7; numbers use the shortest round-trip form (std::to_chars).
struct JsonOut {
  std::string s;
  std::ostream* sink = nullptr;  // where full buffers go (nullptr: s keeps everything)
  // Between events: hand the buffer on once it holds 1 MiB, so a long run's trace is never
  // in memory whole (the 16 s workstation run's is 0.24 GB).
  void drain(bool all = false) {
    if (sink && (all || s.size() >= (std::size_t{1} << 20))) {
      sink->write(s.data(), static_cast<std::streamsize>(s.size()));
      s.clear();
    }
  }
  void str(std::string_view v) {
    s += '"';
    for (const char c : v) {
      const auto u = static_cast<unsigned char>(c);
      if (c == '"' || c == '\\') {
        s += '\\';
        s += c;
      } else if (u < 0x20) {
        char buf[8];
        std::snprintf(buf, sizeof buf, "\\u%04x", u);
        s += buf;
      } else {
        s += c;
      }
    }
    s += '"';
  }
  template <class T>
  void num(T v) {
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    s.append(buf, r.ptr);
  }
  void key(std::string_view k, bool first = false) {  // ,"k":  (keys are plain identifiers)
    if (!first) s += ',';
    s += '"';
    s += k;
    s += "\":";
  }
  void ph_pid_tid(char ph, int pid, int tid) {  // ,"ph":"X","pid":1,"tid":2
    s += ",\"ph\":\"";
    s += ph;
    s += "\",\"pid\":";
    num(pid);
    s += ",\"tid\":";
    num(tid);
  }
};

}  // namespace

// Timelines as Chrome trace JSON (the Trace Event Format's "X" complete events and "M"
// metadata events): one process per node, one per channel group; per device and per
// channel resource a "planned" and an "actual" track. Perfetto drops a complete event that
// overlaps another on its track without nesting in it, and both can happen on one device
// (a plan committed after reality ran ahead starts before an earlier one's planned end;
// channels sharing a resource run at once), so each track is split into as few lanes as
// keep its slices apart: a slice goes to the first lane free at its start, in order of
// start. Each lane is a thread of its own ("A0.cpu3 actual", "A0.cpu3 actual #2", ...).
void write_chrome_trace(const Schedule& s, bool include_actual, std::ostream& out) {
  const DeviceGraph& g = s.graph();
  const JobPool& pool = s.pool();
  const int pid_channels = static_cast<int>(g.nodes.size());
  const std::size_t n_tracks = g.computes.size() + g.resources.size();
  // Pass 1: every slice in emission order (activity id, planned before actual, resources in
  // channel order), its track, and then its lane.
  struct Slice {
    double ts, dur;
    std::uint32_t group;  // track * 2 + actual
    std::uint32_t lane = 0;
  };
  std::vector<Slice> slices;
  auto for_each_slice = [&](auto&& f) {
    for (ActivityId id = 0; id < static_cast<ActivityId>(s.activity_count()); ++id) {
      const Activity& a = s.activity(id);
      if (a.cancelled) continue;  // withdrawn before it ran: nothing to show (jobs.csv lists it)
      for (const bool actual : {false, true}) {
        if (actual && !(include_actual && a.state == ActivityState::Done)) continue;
        const double ts = (actual ? a.start : a.planned_start) * 1e6;
        const double dur = ((actual ? a.end : a.planned_end) - (actual ? a.start : a.planned_start)) * 1e6;
        if (a.kind == ActivityKind::Exec) {
          f(id, a, actual, ts, dur, static_cast<std::size_t>(a.device));
        } else {
          for (ResourceId r : g.channels[a.channel].resources) f(id, a, actual, ts, dur, g.computes.size() + static_cast<std::size_t>(r));
        }
      }
    }
  };
  for_each_slice([&](ActivityId, const Activity&, bool actual, double ts, double dur, std::size_t track) {
    slices.push_back({ts, dur, static_cast<std::uint32_t>(track * 2 + (actual ? 1 : 0))});
  });
  std::vector<std::uint32_t> order(slices.size());
  for (std::uint32_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return slices[a].group != slices[b].group ? slices[a].group < slices[b].group : slices[a].ts < slices[b].ts;
  });
  std::vector<std::uint32_t> lanes_of(n_tracks * 2, 0);  // lanes used per group
  {
    std::vector<double> lane_end;  // of the group being filled
    std::uint32_t group = ~0u;
    for (const std::uint32_t i : order) {
      Slice& sl = slices[i];
      if (sl.group != group) {
        group = sl.group;
        lane_end.clear();
      }
      std::uint32_t lane = 0;
      while (lane < lane_end.size() && lane_end[lane] > sl.ts) ++lane;
      if (lane == lane_end.size()) lane_end.push_back(0);
      lane_end[lane] = sl.ts + sl.dur;
      sl.lane = lane;
      lanes_of[group] = std::max<std::uint32_t>(lanes_of[group], lane + 1);
    }
  }
  // Thread ids: per process, the lanes of each track in track order, planned then actual.
  std::vector<std::uint32_t> first_tid(n_tracks * 2, 0);
  {
    std::vector<std::uint32_t> next_tid(g.nodes.size() + 1, 0);
    for (std::size_t t = 0; t < n_tracks; ++t) {
      const auto pid = static_cast<std::size_t>(t < g.computes.size() ? std::max(0, g.computes[t].node) : pid_channels);
      for (std::size_t k = 0; k < 2; ++k) {
        first_tid[t * 2 + k] = next_tid[pid];
        next_tid[pid] += std::max<std::uint32_t>(1, lanes_of[t * 2 + k]);
      }
    }
  }

  JsonOut o;
  o.sink = &out;
  o.s.reserve((std::size_t{1} << 20) + 4096);
  o.s += "{\"displayTimeUnit\":\"ms\",\"otherData\":{\"platform\":";
  o.str(g.name);
  o.s += "},\"traceEvents\":[";
  bool first = true;
  auto begin_event = [&] {
    if (!first) o.s += ',';
    first = false;
  };
  auto meta = [&](int pid, int tid, const char* what, const std::string& name) {
    begin_event();
    o.s += "{\"args\":{\"name\":";
    o.str(name);
    o.s += "},\"name\":\"";
    o.s += what;
    o.s += '"';
    o.ph_pid_tid('M', pid, tid);
    o.s += '}';
  };
  auto sort_index = [&](int pid, int tid) {  // tracks in tid order, as laid out above
    begin_event();
    o.s += "{\"args\":{\"sort_index\":";
    o.num(tid);
    o.s += "},\"name\":\"thread_sort_index\"";
    o.ph_pid_tid('M', pid, tid);
    o.s += '}';
  };
  for (std::size_t n = 0; n < g.nodes.size(); ++n) meta(static_cast<int>(n), 0, "process_name", g.nodes[n].name + " (compute)");
  meta(pid_channels, 0, "process_name", "channels");
  for (std::size_t t = 0; t < n_tracks; ++t) {
    const bool compute = t < g.computes.size();
    const int pid = compute ? std::max(0, g.computes[t].node) : pid_channels;
    const std::string& name = compute ? g.computes[t].name : g.resources[t - g.computes.size()].name;
    for (std::size_t k = 0; k < 2; ++k) {
      if (k == 1 && !include_actual) continue;
      for (std::uint32_t l = 0; l < std::max<std::uint32_t>(1, lanes_of[t * 2 + k]); ++l) {
        const int tid = static_cast<int>(first_tid[t * 2 + k] + l);
        meta(pid, tid, "thread_name", name + (k ? " actual" : " planned") + (l ? " #" + std::to_string(l + 1) : ""));
        sort_index(pid, tid);
      }
    }
  }
  // One "X" event; `args` is the inside of its args object (keys in alphabetical order, like the rest).
  auto event = [&](std::string_view args, const std::string& name, const char* cat, double ts, double dur, int pid, int tid) {
    begin_event();
    o.s += "{\"args\":{";
    o.s += args;
    o.s += "},\"cat\":\"";
    o.s += cat;
    o.s += "\",\"dur\":";
    o.num(dur);
    o.s += ",\"name\":";
    o.str(name);
    o.ph_pid_tid('X', pid, tid);
    o.s += ",\"ts\":";
    o.num(ts);
    o.s += '}';
    o.drain();
  };
  // Pass 2: the events, in the order of pass 1 (each slice finds its lane by its index).
  JsonOut args_out;
  ActivityId args_for = kNone;
  bool args_actual = false;
  std::size_t k = 0;
  for_each_slice([&](ActivityId id, const Activity& a, bool actual, double ts, double dur, std::size_t track) {
    const bool exec = a.kind == ActivityKind::Exec;
    const char* cat = exec ? (actual ? "E-job,actual" : "E-job,planned") : (actual ? "T-job,actual" : "T-job,planned");
    JsonOut& w = args_out;
    if (args_for != id || args_actual != actual) {  // the args once per activity (a T-job is on each of its resources)
      args_for = id;
      args_actual = actual;
      w.s.clear();
      w.key("activity", true);
      w.num(id);
      if (exec) {
        w.key("job");
        w.str(pool.job(a.job).name);
        w.key("setup_us");
        w.num(a.setup * 1e6);
        w.key("type");
        w.str(g.job_types[pool.job(a.job).type]);
      } else {
        w.key("block");
        w.str(pool.block(a.block).name);
        w.key("bytes");
        w.num(a.bytes);
        w.key("channel");
        w.str(g.channels[a.channel].name);
        if (a.job != kNone) {
          w.key("job");
          w.str(pool.job(a.job).name);
        }
        w.key("move");
        w.s += a.move ? "true" : "false";
      }
    }
    const Slice& sl = slices[k++];
    const int pid = exec ? std::max(0, g.computes[a.device].node) : pid_channels;
    const int tid = static_cast<int>(first_tid[track * 2 + (actual ? 1 : 0)] + sl.lane);
    event(w.s, exec ? pool.job(a.job).name : pool.block(a.block).name, cat, ts, dur, pid, tid);
  });
  o.s += "]}\n";
  o.drain(true);
}

std::string chrome_trace_json(const Schedule& s, bool include_actual) {
  std::ostringstream out;
  write_chrome_trace(s, include_actual, out);
  return std::move(out).str();
}

namespace {

// RFC 4180: a field with a comma, quote or line break is quoted, its quotes doubled.
void append_csv_field(std::string& row, std::string_view v) {
  if (v.find_first_of(",\"\r\n") == std::string_view::npos) {
    row += v;
    return;
  }
  row += '"';
  for (const char c : v) {
    if (c == '"') row += '"';
    row += c;
  }
  row += '"';
}

// As printf's "%.9f" writes it (std::to_chars with a precision: the same digits).
void append_fixed9(std::string& row, double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed, 9);
  row.append(buf, r.ec == std::errc() ? r.ptr : buf);
}

template <class Int>
void append_int(std::string& row, Int v) {
  char buf[24];
  row.append(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}

}  // namespace

void write_jobs_csv(const Schedule& s, std::ostream& out) {
  const DeviceGraph& g = s.graph();
  const JobPool& pool = s.pool();
  // `created`: when the E-job (for a T-job: the E-job it fetches for) entered the queue, so
  // its wait is actual_start - created.
  out << "activity,kind,job,type,device_or_channel,block,bytes,planned_start,planned_end,actual_start,actual_end,state,"
         "created\n";
  // Rows are built in one buffer and written in chunks (a long run has ~10^6 of them).
  std::string rows;
  for (ActivityId id = 0; id < static_cast<ActivityId>(s.activity_count()); ++id) {
    const Activity& a = s.activity(id);
    const bool done = a.state == ActivityState::Done;
    const bool exec = a.kind == ActivityKind::Exec;
    Bytes bytes = a.bytes;
    if (exec)
      for (BlockId b : pool.job(a.job).inputs) bytes += pool.block(b).bytes;
    append_int(rows, id);
    rows += exec ? ",E," : ",T,";
    if (a.job != kNone) append_csv_field(rows, pool.job(a.job).name);
    rows += ',';
    append_csv_field(rows, exec ? std::string_view(g.job_types[pool.job(a.job).type]) : std::string_view("transfer"));
    rows += ',';
    append_csv_field(rows, exec ? g.computes[a.device].name : g.channels[a.channel].name);
    rows += ',';
    if (a.block != kNone) append_csv_field(rows, pool.block(a.block).name);
    rows += ',';
    append_int(rows, bytes);
    rows += ',';
    append_fixed9(rows, a.planned_start);
    rows += ',';
    append_fixed9(rows, a.planned_end);
    rows += ',';
    if (done) {
      append_fixed9(rows, a.start);
      rows += ',';
      append_fixed9(rows, a.end);
      rows += ',';
    } else {
      rows += ",,";
    }
    rows += a.state == ActivityState::Failed ? "aborted" : a.cancelled ? "cancelled" : done ? "done" : "planned";
    rows += ',';
    if (a.job != kNone) append_fixed9(rows, pool.job(a.job).created);
    rows += '\n';
    if (rows.size() > (1u << 20)) {
      out.write(rows.data(), static_cast<std::streamsize>(rows.size()));
      rows.clear();
    }
  }
  out.write(rows.data(), static_cast<std::streamsize>(rows.size()));
}

std::string jobs_csv(const Schedule& s) {
  std::ostringstream out;
  write_jobs_csv(s, out);
  return std::move(out).str();
}

}  // namespace rayline
