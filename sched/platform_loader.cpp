// Platform files (schema: platforms/README.md). Node types are templates; nodes
// instantiate them; networks join node memories through per-node NIC resources.
#include "sched/platform_loader.hpp"

#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <queue>
#include <set>
#include <sstream>

#include "sched/error.hpp"
#include "sched/units.hpp"

namespace rayline {

using nlohmann::json;

namespace {

const std::vector<std::string> kDefaultJobTypes = {"RayIntersect", "ShadowIntersect", "GenerateRays", "Shade",
                                                   "Accumulate", "AdditiveCompose", "Compute"};

struct Ctx {
  std::string file;

  [[noreturn]] void fail(const std::string& field, const std::string& msg) const { throw InputError(file, field, msg); }

  void keys(const json& o, const std::set<std::string>& allowed, const std::string& field) const {
    if (!o.is_object()) fail(field, "expected an object");
    for (auto it = o.begin(); it != o.end(); ++it)
      if (!allowed.count(it.key())) fail(field + "." + it.key(), "unknown key");
  }
  const json& need(const json& o, const char* k, const std::string& field) const {
    auto it = o.find(k);
    if (it == o.end()) fail(field + "." + k, "missing");
    return *it;
  }
  std::string str(const json& o, const char* k, const std::string& field) const {
    const json& v = need(o, k, field);
    if (!v.is_string() || v.get<std::string>().empty()) fail(field + "." + k, "expected a non-empty string");
    return v.get<std::string>();
  }
  std::string opt_str(const json& o, const char* k, const std::string& field, const std::string& def) const {
    return o.contains(k) ? str(o, k, field) : def;
  }
  const json& arr(const json& o, const char* k, const std::string& field, bool required = true) const {
    static const json empty = json::array();
    auto it = o.find(k);
    if (it == o.end()) {
      if (required) fail(field + "." + k, "missing");
      return empty;
    }
    if (!it->is_array()) fail(field + "." + k, "expected an array");
    return *it;
  }
  double bytes(const json& o, const char* k, const std::string& field) const {
    try {
      return units::parse_bytes(str(o, k, field));
    } catch (const std::invalid_argument& e) {
      fail(field + "." + k, e.what());
    }
  }
  double bandwidth(const json& o, const char* k, const std::string& field) const {
    try {
      return units::parse_bandwidth(str(o, k, field));
    } catch (const std::invalid_argument& e) {
      fail(field + "." + k, e.what());
    }
  }
  double duration(const json& o, const char* k, const std::string& field) const {
    try {
      return units::parse_duration(str(o, k, field));
    } catch (const std::invalid_argument& e) {
      fail(field + "." + k, e.what());
    }
  }
};

std::string at(const std::string& field, std::size_t i) { return field + "[" + std::to_string(i) + "]"; }

}  // namespace

DeviceGraph parse_platform(std::string_view text, const std::string& file) {
  Ctx cx{file};
  json root;
  try {
    root = json::parse(text);
  } catch (const json::parse_error& e) {
    cx.fail("", std::string("invalid JSON: ") + e.what());
  }
  cx.keys(root, {"name", "description", "job_types", "node_types", "nodes", "networks"}, "$");
  DeviceGraph g;
  g.source_file = file;
  g.name = cx.str(root, "name", "$");
  if (root.contains("job_types")) {
    const json& jt = cx.arr(root, "job_types", "$");
    for (std::size_t i = 0; i < jt.size(); ++i) {
      if (!jt[i].is_string()) cx.fail(at("job_types", i), "expected a string");
      if (g.job_type(jt[i].get<std::string>()) != kNone) cx.fail(at("job_types", i), "duplicate job type");
      g.job_types.push_back(jt[i].get<std::string>());
    }
  } else {
    g.job_types = kDefaultJobTypes;
  }
  const json& types = cx.need(root, "node_types", "$");
  if (!types.is_object() || types.empty()) cx.fail("node_types", "expected a non-empty object of node types");

  struct PendingTiming {
    DeviceId device;
    const json* timing;
    std::string field;
  };
  std::vector<PendingTiming> timings;
  std::map<std::string, std::map<std::string, MemId>> node_mem;  // node -> local memory name -> id

  const json& nodes = cx.arr(root, "nodes", "$");
  if (nodes.empty()) cx.fail("nodes", "a platform needs at least one node");
  for (std::size_t ni = 0; ni < nodes.size(); ++ni) {
    const std::string nf = at("nodes", ni);
    cx.keys(nodes[ni], {"name", "type"}, nf);
    const std::string nname = cx.str(nodes[ni], "name", nf);
    if (g.find_node(nname) != kNone) cx.fail(nf + ".name", "duplicate node name '" + nname + "'");
    const std::string tname = cx.str(nodes[ni], "type", nf);
    if (!types.contains(tname)) cx.fail(nf + ".type", "unknown node type '" + tname + "'");
    const json& t = types[tname];
    const std::string tf = "node_types." + tname;
    cx.keys(t, {"description", "memory", "compute", "channels"}, tf);
    const auto node_id = static_cast<NodeId>(g.nodes.size());
    g.nodes.push_back({nname, {}, {}});
    auto& local = node_mem[nname];
    const json& mems = cx.arr(t, "memory", tf);
    if (mems.empty()) cx.fail(tf + ".memory", "a node needs at least one memory device");
    for (std::size_t i = 0; i < mems.size(); ++i) {
      const std::string f = at(tf + ".memory", i);
      cx.keys(mems[i], {"name", "kind", "capacity"}, f);
      MemoryDevice m;
      const std::string local_name = cx.str(mems[i], "name", f);
      if (local.count(local_name)) cx.fail(f + ".name", "duplicate memory device '" + local_name + "'");
      m.name = nname + "." + local_name;
      const std::string kind = cx.str(mems[i], "kind", f);
      if (kind == "disk") m.kind = MemoryKind::Disk;
      else if (kind == "host") m.kind = MemoryKind::Host;
      else if (kind == "gpu") m.kind = MemoryKind::Gpu;
      else cx.fail(f + ".kind", "unknown memory kind '" + kind + "' (disk, host or gpu)");
      const double cap = cx.bytes(mems[i], "capacity", f);
      if (!(cap > 0)) cx.fail(f + ".capacity", "must be > 0");
      m.capacity = static_cast<Bytes>(cap);
      m.node = node_id;
      local[local_name] = static_cast<MemId>(g.memories.size());
      g.nodes.back().memories.push_back(static_cast<MemId>(g.memories.size()));
      g.memories.push_back(std::move(m));
    }
    const json& comps = cx.arr(t, "compute", tf, false);
    for (std::size_t i = 0; i < comps.size(); ++i) {
      const std::string f = at(tf + ".compute", i);
      cx.keys(comps[i], {"name", "kind", "count", "memory", "timing"}, f);
      const std::string cname = cx.str(comps[i], "name", f);
      const std::string kind = cx.str(comps[i], "kind", f);
      ComputeKind ck;
      if (kind == "cpu") ck = ComputeKind::Cpu;
      else if (kind == "gpu") ck = ComputeKind::Gpu;
      else cx.fail(f + ".kind", "unknown compute kind '" + kind + "' (cpu or gpu)");
      int count = 1;
      if (comps[i].contains("count")) {
        if (!comps[i]["count"].is_number_integer() || comps[i]["count"].get<long long>() < 1 || comps[i]["count"].get<long long>() > 65536)
          cx.fail(f + ".count", "expected an integer from 1 to 65536");
        count = comps[i]["count"].get<int>();
      }
      if (!comps[i].contains("memory")) cx.fail(f + ".memory", "missing: every compute device is attached to a memory device");
      const std::string mem = cx.str(comps[i], "memory", f);
      if (!local.count(mem)) cx.fail(f + ".memory", "unknown memory device '" + mem + "' in node type '" + tname + "'");
      const json* timing = comps[i].contains("timing") ? &comps[i]["timing"] : nullptr;
      for (int k = 0; k < count; ++k) {
        ComputeDevice d;
        d.name = nname + "." + (count > 1 ? cname + std::to_string(k) : cname);
        d.model = tname + "." + cname;
        d.kind = ck;
        d.memory = local[mem];
        d.node = node_id;
        const auto id = static_cast<DeviceId>(g.computes.size());
        g.nodes.back().computes.push_back(id);
        g.computes.push_back(std::move(d));
        if (timing) timings.push_back({id, timing, f + ".timing"});
      }
    }
    const json& chans = cx.arr(t, "channels", tf, false);
    for (std::size_t i = 0; i < chans.size(); ++i) {
      const std::string f = at(tf + ".channels", i);
      cx.keys(chans[i], {"name", "kind", "between", "duplex", "latency", "bandwidth"}, f);
      const std::string cname = cx.str(chans[i], "name", f);
      const json& between = cx.arr(chans[i], "between", f);
      if (between.size() != 2 || !between[0].is_string() || !between[1].is_string())
        cx.fail(f + ".between", "expected two memory device names");
      MemId ends[2];
      for (int e = 0; e < 2; ++e) {
        const std::string mname = between[static_cast<std::size_t>(e)].get<std::string>();
        if (!local.count(mname)) cx.fail(at(f + ".between", static_cast<std::size_t>(e)), "unknown memory device '" + mname + "'");
        ends[e] = local[mname];
      }
      if (ends[0] == ends[1]) cx.fail(f + ".between", "a channel joins two different memory devices");
      const std::string duplex = cx.opt_str(chans[i], "duplex", f, "full");
      if (duplex != "half" && duplex != "full") cx.fail(f + ".duplex", "expected \"half\" or \"full\"");
      const double bw = cx.bandwidth(chans[i], "bandwidth", f);
      const double lat = cx.duration(chans[i], "latency", f);
      const std::string kind = cx.opt_str(chans[i], "kind", f, cname);
      const std::string base = nname + "." + cname;
      std::vector<ResourceId> res;
      if (duplex == "half") {
        g.resources.push_back({base, bw});
        res = {static_cast<ResourceId>(g.resources.size() - 1), static_cast<ResourceId>(g.resources.size() - 1)};
      } else {
        g.resources.push_back({base + ".fwd", bw});
        g.resources.push_back({base + ".rev", bw});
        res = {static_cast<ResourceId>(g.resources.size() - 2), static_cast<ResourceId>(g.resources.size() - 1)};
      }
      for (int dir = 0; dir < 2; ++dir) {
        Channel c;
        const MemId a = ends[dir], b = ends[1 - dir];
        c.name = base + ":" + g.memories[a].name.substr(nname.size() + 1) + "->" + g.memories[b].name.substr(nname.size() + 1);
        c.kind = kind;
        c.from = a;
        c.to = b;
        c.latency = lat;
        c.bandwidth = bw;
        c.resources = {res[static_cast<std::size_t>(dir)]};
        g.channels.push_back(std::move(c));
      }
    }
  }

  const json& nets = cx.arr(root, "networks", "$", false);
  for (std::size_t ni = 0; ni < nets.size(); ++ni) {
    const std::string f = at("networks", ni);
    cx.keys(nets[ni], {"name", "kind", "latency", "duplex", "members"}, f);
    const std::string name = cx.str(nets[ni], "name", f);
    const std::string kind = cx.opt_str(nets[ni], "kind", f, "lan");
    const double lat = cx.duration(nets[ni], "latency", f);
    const std::string duplex = cx.opt_str(nets[ni], "duplex", f, "full");
    if (duplex != "half" && duplex != "full") cx.fail(f + ".duplex", "expected \"half\" or \"full\"");
    const json& members = cx.arr(nets[ni], "members", f);
    if (members.size() < 2) cx.fail(f + ".members", "a network joins at least two nodes");
    struct Member { std::string node; MemId mem; double bw; ResourceId out, in; };
    std::vector<Member> ms;
    std::set<std::string> seen;
    for (std::size_t i = 0; i < members.size(); ++i) {
      const std::string mf = at(f + ".members", i);
      cx.keys(members[i], {"node", "memory", "bandwidth"}, mf);
      const std::string node = cx.str(members[i], "node", mf);
      if (!node_mem.count(node)) cx.fail(mf + ".node", "unknown node '" + node + "'");
      if (!seen.insert(node).second) cx.fail(mf + ".node", "node '" + node + "' is listed twice");
      const std::string mem = cx.opt_str(members[i], "memory", mf, "ram");
      if (!node_mem[node].count(mem)) cx.fail(mf + ".memory", "unknown memory device '" + mem + "' on node '" + node + "'");
      Member m{node, node_mem[node][mem], cx.bandwidth(members[i], "bandwidth", mf), kNone, kNone};
      const std::string base = node + "." + name;
      if (duplex == "full") {
        g.resources.push_back({base + ".out", m.bw});
        m.out = static_cast<ResourceId>(g.resources.size() - 1);
        g.resources.push_back({base + ".in", m.bw});
        m.in = static_cast<ResourceId>(g.resources.size() - 1);
      } else {
        g.resources.push_back({base + ".nic", m.bw});
        m.out = m.in = static_cast<ResourceId>(g.resources.size() - 1);
      }
      ms.push_back(m);
    }
    for (const Member& a : ms)
      for (const Member& b : ms) {
        if (a.node == b.node) continue;
        Channel c;
        c.name = name + ":" + a.node + "->" + b.node;
        c.kind = kind;
        c.from = a.mem;
        c.to = b.mem;
        c.latency = lat;
        c.bandwidth = std::min(a.bw, b.bw);  // the slower NIC limits the pair
        c.resources = {a.out, b.in};
        g.channels.push_back(std::move(c));
      }
  }

  g.finalize();
  for (const PendingTiming& pt : timings) {
    const json& t = *pt.timing;
    if (!t.is_object()) cx.fail(pt.field, "expected an object of job types");
    for (auto it = t.begin(); it != t.end(); ++it) {
      const std::string f = pt.field + "." + it.key();
      const JobTypeId j = g.job_type(it.key());
      if (j == kNone) cx.fail(f, "unknown job type '" + it.key() + "' (not in job_types)");
      cx.keys(it.value(), {"setup", "rate"}, f);
      ExecCoefficients& c = g.timing.at(pt.device, j);
      c.supported = true;
      c.setup = it.value().contains("setup") ? cx.duration(it.value(), "setup", f) : 0;
      const json& rate = cx.need(it.value(), "rate", f);
      if (!rate.is_object() || rate.empty()) cx.fail(f + ".rate", "expected an object: data kind -> throughput, e.g. {\"RayQueue\": \"32MB/s\"}");
      for (auto r = rate.begin(); r != rate.end(); ++r) {
        DataKind k;
        if (!parse_data_kind(r.key(), k)) cx.fail(f + ".rate." + r.key(), "unknown data kind");
        c.rate[static_cast<int>(k)] = 1.0 / cx.bandwidth(rate, r.key().c_str(), f + ".rate");  // Eq. 2: seconds per byte
      }
    }
  }
  // Every memory device a compute device works from must be reachable from a disk (where
  // the scene lives), or nothing could ever run there.
  std::vector<char> reach(g.memories.size(), 0);
  std::queue<MemId> q;
  for (std::size_t m = 0; m < g.memories.size(); ++m)
    if (g.memories[m].kind == MemoryKind::Disk) {
      reach[m] = 1;
      q.push(static_cast<MemId>(m));
    }
  if (q.empty()) cx.fail("node_types", "no memory device of kind \"disk\": nothing can hold the scene");
  while (!q.empty()) {
    const MemId m = q.front();
    q.pop();
    for (ChannelId c : g.out_channels(m))
      if (!reach[g.channels[c].to]) {
        reach[g.channels[c].to] = 1;
        q.push(g.channels[c].to);
      }
  }
  for (const ComputeDevice& d : g.computes)
    if (!reach[d.memory])
      cx.fail("memory[" + g.memories[d.memory].name + "]",
              "unreachable from every disk: compute device '" + d.name + "' could never get data");
  return g;
}

DeviceGraph load_platform(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open platform file");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_platform(ss.str(), path);
}

}  // namespace rayline
