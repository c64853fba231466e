// Platform files -> device connectivity graph (DCG, Sec. 3.2, Fig. 2). Schema and every
// assumed number: platforms/README.md. In short:
//   * node_types are templates (memory devices, compute devices, intra-node channels);
//   * nodes instantiate a type and may patch it: an entry of the node's memory/compute/
//     channels lists with the name of a template entry is merged into it (RFC 7396 merge
//     patch, null deletes a key), an entry with a new name is added;
//   * networks join one memory device per member node through per-node NIC resources.
// Every problem is an InputError(file, JSON path of the field, message). nlohmann_json
// stays inside this file (the header does not include it).
#include "sched/io/platform_loader.hpp"

#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <queue>
#include <set>
#include <sstream>
#include <vector>

#include "common/error.hpp"
#include "common/input_file.hpp"
#include "common/units.hpp"

namespace rayline {

using nlohmann::json;

namespace {

const std::vector<std::string> kDefaultJobTypes = {"RayIntersect", "ShadowIntersect", "GenerateRays", "Shade",
                                                   "Accumulate", "AdditiveCompose", "Compute"};

std::string join(const std::string& field, const std::string& key) { return field.empty() ? key : field + "." + key; }
std::string at(const std::string& field, std::size_t i) { return field + "[" + std::to_string(i) + "]"; }

std::string type_name(const json& v) { return v.type_name(); }

struct Ctx {
  std::string file;

  [[noreturn]] void fail(const std::string& field, const std::string& msg) const { throw InputError(file, field, msg); }

  // Unknown keys are errors: a typo ("bandwith") must not silently fall back to a default.
  void keys(const json& o, const std::set<std::string>& allowed, const std::string& field) const {
    if (!o.is_object()) fail(field.empty() ? "(top level)" : field, "expected an object, got " + type_name(o));
    for (auto it = o.begin(); it != o.end(); ++it)
      if (!allowed.count(it.key())) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(join(field, it.key()), "unknown key (allowed: " + list + ")");
      }
  }
  const json& need(const json& o, const char* k, const std::string& field) const {
    auto it = o.find(k);
    if (it == o.end()) fail(join(field, k), "missing");
    return *it;
  }
  std::string str(const json& o, const char* k, const std::string& field) const {
    const json& v = need(o, k, field);
    if (!v.is_string() || v.get<std::string>().empty())
      fail(join(field, k), "expected a non-empty string, got " + type_name(v));
    return v.get<std::string>();
  }
  std::string opt_str(const json& o, const char* k, const std::string& field, const std::string& def) const {
    return o.contains(k) ? str(o, k, field) : def;
  }
  const json& arr(const json& o, const char* k, const std::string& field, bool required = true) const {
    static const json empty = json::array();
    auto it = o.find(k);
    if (it == o.end()) {
      if (required) fail(join(field, k), "missing");
      return empty;
    }
    if (!it->is_array()) fail(join(field, k), "expected an array, got " + type_name(*it));
    return *it;
  }
  template <class F>
  double quantity(const json& o, const char* k, const std::string& field, F parse) const {
    const std::string s = str(o, k, field);
    try {
      return parse(s);
    } catch (const std::invalid_argument& e) {
      fail(join(field, k), e.what());
    }
  }
  double bytes(const json& o, const char* k, const std::string& f) const { return quantity(o, k, f, units::parse_bytes); }
  double bandwidth(const json& o, const char* k, const std::string& f) const {
    return quantity(o, k, f, units::parse_bandwidth);
  }
  double duration(const json& o, const char* k, const std::string& f) const {
    return quantity(o, k, f, units::parse_duration);
  }
  Duplex duplex(const json& o, const std::string& f) const {
    const std::string d = opt_str(o, "duplex", f, "full");
    if (d == "half") return Duplex::Half;
    if (d == "full") return Duplex::Full;
    fail(join(f, "duplex"), "expected \"half\" (one medium shared by both directions) or \"full\", got \"" + d + "\"");
  }
};

// One entry of a node's memory/compute/channels list after applying the node's patches,
// with the JSON path to report its errors at (the node's own entry when it touched it).
struct Entry {
  json value;
  std::string field;
};

std::vector<Entry> merged_list(const Ctx& cx, const json* type, const std::string& tf, const json& node,
                               const std::string& nf, const char* key) {
  std::vector<Entry> out;
  auto name_of = [&](const json& e, const std::string& f) {
    if (!e.is_object()) cx.fail(f, "expected an object, got " + type_name(e));
    return cx.str(e, "name", f);
  };
  if (type) {
    const json& list = cx.arr(*type, key, tf, false);
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string f = at(join(tf, key), i);
      name_of(list[i], f);
      out.push_back({list[i], f});
    }
  }
  const json& patches = cx.arr(node, key, nf, false);
  for (std::size_t i = 0; i < patches.size(); ++i) {
    const std::string f = at(join(nf, key), i);
    const std::string n = name_of(patches[i], f);
    bool merged = false;
    for (Entry& e : out)
      if (e.value.is_object() && e.value.value("name", std::string()) == n) {
        e.value.merge_patch(patches[i]);
        e.field = f;
        merged = true;
        break;
      }
    if (!merged) out.push_back({patches[i], f});
  }
  return out;
}

struct PendingTiming {
  DeviceId device;
  json timing;
  std::string field;
};

}  // namespace

DeviceGraph parse_platform(std::string_view text, const std::string& file) {
  Ctx cx{file};
  json root;
  // JSON itself lets a key repeat (the last one wins); in a platform file that is almost
  // always a copy-paste slip ("A" defined twice), so reject it with its path.
  struct Frame {
    bool object;
    std::string name, key;
    std::set<std::string> keys;
  };
  std::vector<Frame> stack;
  auto path = [&] {
    std::string p;
    for (std::size_t i = 1; i < stack.size(); ++i)
      p += stack[i].name == "[]" ? "[]" : (p.empty() ? "" : ".") + stack[i].name;
    return p;
  };
  const json::parser_callback_t no_duplicate_keys = [&](int, json::parse_event_t ev, json& v) {
    using E = json::parse_event_t;
    if (ev == E::object_start || ev == E::array_start) {
      std::string name;
      if (!stack.empty()) name = stack.back().object ? stack.back().key : "[]";
      stack.push_back({ev == E::object_start, name, "", {}});
    } else if (ev == E::object_end || ev == E::array_end) {
      if (!stack.empty()) stack.pop_back();
    } else if (ev == E::key && !stack.empty()) {
      const std::string k = v.is_string() ? v.get<std::string>() : std::string();
      if (!stack.back().keys.insert(k).second) cx.fail(join(path(), k), "duplicate key");
      stack.back().key = k;
    }
    return true;
  };
  try {
    root = json::parse(text, no_duplicate_keys);
  } catch (const json::parse_error& e) {
    // e.what() is "[json.exception.parse_error.101] parse error at line L, column C: ...".
    std::string msg = e.what();
    if (const auto p = msg.find("] "); msg.starts_with("[json.exception") && p != std::string::npos) msg.erase(0, p + 2);
    cx.fail("", "invalid JSON: " + msg);
  }
  cx.keys(root, {"name", "description", "job_types", "node_types", "nodes", "networks"}, "");
  DeviceGraph g;
  g.source_file = file;
  g.name = cx.str(root, "name", "");
  if (root.contains("description") && !root["description"].is_string()) cx.fail("description", "expected a string");

  // Job types (JobTypeId order). Default: the path-tracing job graph of Fig. 3 + Compute.
  if (root.contains("job_types")) {
    const json& jt = cx.arr(root, "job_types", "");
    if (jt.empty()) cx.fail("job_types", "expected at least one job type");
    for (std::size_t i = 0; i < jt.size(); ++i) {
      if (!jt[i].is_string() || jt[i].get<std::string>().empty()) cx.fail(at("job_types", i), "expected a non-empty string");
      if (g.job_type(jt[i].get<std::string>()) != kNone)
        cx.fail(at("job_types", i), "duplicate job type '" + jt[i].get<std::string>() + "'");
      g.job_types.push_back(jt[i].get<std::string>());
    }
  } else {
    g.job_types = kDefaultJobTypes;
  }

  static const json no_types = json::object();
  const json& types = root.contains("node_types") ? root["node_types"] : no_types;
  if (!types.is_object()) cx.fail("node_types", "expected an object: type name -> node template");
  for (auto it = types.begin(); it != types.end(); ++it)
    cx.keys(it.value(), {"description", "memory", "compute", "channels", "media"}, "node_types." + it.key());

  std::vector<PendingTiming> timings;
  std::map<std::string, std::map<std::string, MemId>> node_mem;  // node -> local memory name -> id
  std::vector<std::string> mem_field;                            // MemId -> JSON path (for errors)

  const json& nodes = cx.arr(root, "nodes", "");
  if (nodes.empty()) cx.fail("nodes", "a platform needs at least one node");
  for (std::size_t ni = 0; ni < nodes.size(); ++ni) {
    const std::string nf = at("nodes", ni);
    const json& node = nodes[ni];
    cx.keys(node, {"name", "type", "description", "memory", "compute", "channels", "media"}, nf);
    const std::string nname = cx.str(node, "name", nf);
    if (nname.find('.') != std::string::npos) cx.fail(join(nf, "name"), "node names may not contain '.'");
    if (g.find_node(nname) != kNone) cx.fail(join(nf, "name"), "duplicate node name '" + nname + "'");
    const json* type = nullptr;
    std::string tf;  // JSON path of the template ("node_types.A")
    std::string model_prefix = nname;
    if (node.contains("type")) {
      const std::string tname = cx.str(node, "type", nf);
      if (!types.contains(tname)) {
        std::string list;
        for (auto it = types.begin(); it != types.end(); ++it) list += (list.empty() ? "" : ", ") + it.key();
        cx.fail(join(nf, "type"), "unknown node type '" + tname + "' (node_types: " + (list.empty() ? "none" : list) + ")");
      }
      type = &types[tname];
      tf = "node_types." + tname;
      model_prefix = tname;
    }
    const auto node_id = static_cast<NodeId>(g.nodes.size());
    g.nodes.push_back({nname, {}, {}});
    auto& local = node_mem[nname];

    // Memory devices: vertices of the DCG.
    const auto mems = merged_list(cx, type, tf, node, nf, "memory");
    if (mems.empty()) cx.fail(join(type ? tf : nf, "memory"), "a node needs at least one memory device");
    for (const Entry& e : mems) {
      const std::string& f = e.field;
      cx.keys(e.value, {"name", "kind", "capacity", "description"}, f);
      MemoryDevice m;
      const std::string local_name = cx.str(e.value, "name", f);
      if (local.count(local_name)) cx.fail(join(f, "name"), "duplicate memory device name '" + local_name + "'");
      m.name = nname + "." + local_name;
      const std::string kind = cx.str(e.value, "kind", f);
      if (kind == "disk") m.kind = MemoryKind::Disk;
      else if (kind == "host") m.kind = MemoryKind::Host;
      else if (kind == "gpu") m.kind = MemoryKind::Gpu;
      else cx.fail(join(f, "kind"), "unknown memory kind '" + kind + "' (expected disk, host or gpu)");
      const double cap = cx.bytes(e.value, "capacity", f);
      if (!(cap > 0)) cx.fail(join(f, "capacity"), "must be > 0");
      if (cap > 9.2e18) cx.fail(join(f, "capacity"), "too large");
      m.capacity = static_cast<Bytes>(cap);
      m.node = node_id;
      local[local_name] = static_cast<MemId>(g.memories.size());
      g.nodes.back().memories.push_back(static_cast<MemId>(g.memories.size()));
      g.memories.push_back(std::move(m));
      mem_field.push_back(f);
    }

    // Compute devices: each attached to exactly one memory device (Sec. 3.2).
    for (const Entry& e : merged_list(cx, type, tf, node, nf, "compute")) {
      const std::string& f = e.field;
      cx.keys(e.value, {"name", "kind", "count", "memory", "timing", "description"}, f);
      const std::string cname = cx.str(e.value, "name", f);
      const std::string kind = cx.str(e.value, "kind", f);
      ComputeKind ck = ComputeKind::Cpu;
      if (kind == "cpu") ck = ComputeKind::Cpu;
      else if (kind == "gpu") ck = ComputeKind::Gpu;
      else cx.fail(join(f, "kind"), "unknown compute kind '" + kind + "' (expected cpu or gpu)");
      int count = 1;
      if (e.value.contains("count")) {
        const json& c = e.value["count"];
        if (!c.is_number_integer() || c.get<long long>() < 1 || c.get<long long>() > 65536)
          cx.fail(join(f, "count"), "expected an integer from 1 to 65536");
        count = c.get<int>();
      }
      if (!e.value.contains("memory"))
        cx.fail(join(f, "memory"), "missing: every compute device is attached to a memory device");
      const std::string mem = cx.str(e.value, "memory", f);
      if (!local.count(mem)) cx.fail(join(f, "memory"), "unknown memory device '" + mem + "' on node '" + nname + "'");
      const bool has_timing = e.value.contains("timing");
      if (has_timing && !e.value["timing"].is_object())
        cx.fail(join(f, "timing"), "expected an object: job type -> {setup, rate}");
      for (int k = 0; k < count; ++k) {
        ComputeDevice d;
        d.name = nname + "." + (count > 1 ? cname + std::to_string(k) : cname);  // "A0.cpu3"
        if (g.find_compute(d.name) != kNone) cx.fail(join(f, "name"), "duplicate compute device name '" + d.name + "'");
        d.model = model_prefix + "." + cname;
        d.kind = ck;
        d.memory = local[mem];
        d.node = node_id;
        const auto id = static_cast<DeviceId>(g.computes.size());
        g.nodes.back().computes.push_back(id);
        g.computes.push_back(std::move(d));
        if (has_timing) timings.push_back({id, e.value["timing"], join(f, "timing")});
      }
    }

    // Shared media inside a node (e.g. one PCIe root complex behind several GPUs): one
    // resource each; every channel that names it in "media" also occupies it, in both
    // directions, so those channels contend (DCG contention, device_graph.hpp).
    std::map<std::string, ResourceId> media;
    for (const Entry& e : merged_list(cx, type, tf, node, nf, "media")) {
      cx.keys(e.value, {"name", "bandwidth", "description"}, e.field);
      const std::string mname = cx.str(e.value, "name", e.field);
      if (media.count(mname)) cx.fail(join(e.field, "name"), "duplicate medium '" + mname + "'");
      g.resources.push_back({nname + "." + mname, cx.bandwidth(e.value, "bandwidth", e.field)});
      media[mname] = static_cast<ResourceId>(g.resources.size() - 1);
    }

    // Intra-node channels: a half-duplex medium (SATA) is one resource for both
    // directions; a full-duplex one (PCIe) one resource per direction.
    std::set<std::string> chan_names;
    for (const Entry& e : merged_list(cx, type, tf, node, nf, "channels")) {
      const std::string& f = e.field;
      cx.keys(e.value, {"name", "kind", "between", "duplex", "latency", "bandwidth", "media", "description"}, f);
      const std::string cname = cx.str(e.value, "name", f);
      std::vector<ResourceId> shared;
      if (e.value.contains("media")) {
        const json& ms = cx.arr(e.value, "media", f);
        for (std::size_t k = 0; k < ms.size(); ++k) {
          const std::string mf = at(join(f, "media"), k);
          if (!ms[k].is_string()) cx.fail(mf, "expected the name of a medium");
          auto it = media.find(ms[k].get<std::string>());
          if (it == media.end()) cx.fail(mf, "unknown medium '" + ms[k].get<std::string>() + "' on node '" + nname + "'");
          shared.push_back(it->second);
        }
      }
      if (!chan_names.insert(cname).second) cx.fail(join(f, "name"), "duplicate channel name '" + cname + "'");
      const json& between = cx.arr(e.value, "between", f);
      if (between.size() != 2) cx.fail(join(f, "between"), "expected two memory device names, e.g. [\"disk\", \"ram\"]");
      MemId ends[2];
      for (std::size_t k = 0; k < 2; ++k) {
        const std::string ef = at(join(f, "between"), k);
        if (!between[k].is_string()) cx.fail(ef, "expected a memory device name");
        const std::string mname = between[k].get<std::string>();
        if (!local.count(mname)) cx.fail(ef, "unknown memory device '" + mname + "' on node '" + nname + "'");
        ends[k] = local[mname];
      }
      if (ends[0] == ends[1]) cx.fail(join(f, "between"), "a channel joins two different memory devices");
      const Duplex dup = cx.duplex(e.value, f);
      const double lat = cx.duration(e.value, "latency", f);
      const double bw = cx.bandwidth(e.value, "bandwidth", f);
      const std::string kind = cx.opt_str(e.value, "kind", f, cname);
      const std::string base = nname + "." + cname;
      ResourceId res[2];
      if (dup == Duplex::Half) {
        g.resources.push_back({base, bw});
        res[0] = res[1] = static_cast<ResourceId>(g.resources.size() - 1);
      } else {
        g.resources.push_back({base + ".fwd", bw});
        g.resources.push_back({base + ".rev", bw});
        res[0] = static_cast<ResourceId>(g.resources.size() - 2);
        res[1] = static_cast<ResourceId>(g.resources.size() - 1);
      }
      for (int dir = 0; dir < 2; ++dir) {
        Channel c;
        const MemId a = ends[dir], b = ends[1 - dir];
        c.name = base + ":" + g.memories[a].name.substr(nname.size() + 1) + "->" +
                 g.memories[b].name.substr(nname.size() + 1);  // "A0.sata:disk->ram"
        c.kind = kind;
        c.from = a;
        c.to = b;
        c.latency = lat;
        c.bandwidth = bw;
        c.resources = {res[dir]};
        c.resources.insert(c.resources.end(), shared.begin(), shared.end());
        g.channels.push_back(std::move(c));
      }
    }
  }

  // Networks: a switched LAN; every member contributes one memory device and its NIC.
  // A channel joins every ordered pair of members at min(NIC_src, NIC_dst) and occupies
  // the sender's outgoing and the receiver's incoming NIC (one shared NIC if half duplex).
  const json& nets = cx.arr(root, "networks", "", false);
  std::set<std::string> net_names;
  for (std::size_t ni = 0; ni < nets.size(); ++ni) {
    const std::string f = at("networks", ni);
    cx.keys(nets[ni], {"name", "kind", "latency", "duplex", "bandwidth", "members", "description"}, f);
    const std::string name = cx.str(nets[ni], "name", f);
    if (!net_names.insert(name).second) cx.fail(join(f, "name"), "duplicate network name '" + name + "'");
    const std::string kind = cx.opt_str(nets[ni], "kind", f, "lan");
    const double lat = cx.duration(nets[ni], "latency", f);
    const Duplex dup = cx.duplex(nets[ni], f);
    const bool has_default_bw = nets[ni].contains("bandwidth");
    const double default_bw = has_default_bw ? cx.bandwidth(nets[ni], "bandwidth", f) : 0;
    const json& members = cx.arr(nets[ni], "members", f);
    if (members.size() < 2) cx.fail(join(f, "members"), "a network joins at least two nodes");
    struct Member {
      std::string node;
      MemId mem;
      double bw;
      ResourceId out, in;
    };
    std::vector<Member> ms;
    std::set<std::string> seen;
    for (std::size_t i = 0; i < members.size(); ++i) {
      const std::string mf = at(join(f, "members"), i);
      cx.keys(members[i], {"node", "memory", "bandwidth"}, mf);
      const std::string node = cx.str(members[i], "node", mf);
      if (!node_mem.count(node)) cx.fail(join(mf, "node"), "unknown node '" + node + "'");
      if (!seen.insert(node).second) cx.fail(join(mf, "node"), "node '" + node + "' is listed twice");
      const std::string mem = cx.opt_str(members[i], "memory", mf, "ram");
      if (!node_mem[node].count(mem))
        cx.fail(join(mf, "memory"), "unknown memory device '" + mem + "' on node '" + node + "'");
      double bw = default_bw;
      if (members[i].contains("bandwidth")) bw = cx.bandwidth(members[i], "bandwidth", mf);
      else if (!has_default_bw) cx.fail(join(mf, "bandwidth"), "missing (NIC speed; or give the network a bandwidth)");
      Member m{node, node_mem[node][mem], bw, kNone, kNone};
      const std::string base = node + "." + name;
      if (dup == Duplex::Full) {
        g.resources.push_back({base + ".out", bw});
        m.out = static_cast<ResourceId>(g.resources.size() - 1);
        g.resources.push_back({base + ".in", bw});
        m.in = static_cast<ResourceId>(g.resources.size() - 1);
      } else {
        g.resources.push_back({base + ".nic", bw});
        m.out = m.in = static_cast<ResourceId>(g.resources.size() - 1);
      }
      ms.push_back(m);
    }
    for (const Member& a : ms)
      for (const Member& b : ms) {
        if (a.node == b.node) continue;
        Channel c;
        c.name = name + ":" + a.node + "->" + b.node;  // "lan:A0->B"
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

  // Eq. 2 coefficients. A throughput X B/s of an input kind becomes rate = 1/X s per byte;
  // a job type a device does not list is unsupported there.
  for (const PendingTiming& pt : timings) {
    const json& t = pt.timing;
    for (auto it = t.begin(); it != t.end(); ++it) {
      const std::string f = join(pt.field, it.key());
      const JobTypeId j = g.job_type(it.key());
      if (j == kNone) cx.fail(f, "unknown job type '" + it.key() + "' (not in job_types)");
      cx.keys(it.value(), {"setup", "rate"}, f);
      if (it.value().empty()) cx.fail(f, "expected \"setup\" and/or \"rate\"");
      ExecCoefficients& c = g.timing.at(pt.device, j);
      c = ExecCoefficients{};
      c.supported = true;
      c.setup = it.value().contains("setup") ? cx.duration(it.value(), "setup", f) : 0;
      if (it.value().contains("rate")) {
        const json& rate = it.value()["rate"];
        if (!rate.is_object())
          cx.fail(join(f, "rate"), "expected an object: data kind -> throughput, e.g. {\"RayQueue\": \"640MB/s\"}");
        for (auto r = rate.begin(); r != rate.end(); ++r) {
          DataKind k;
          if (!parse_data_kind(r.key(), k)) {
            std::string list;
            for (auto n : kDataKindNames) list += (list.empty() ? "" : ", ") + std::string(n);
            cx.fail(join(join(f, "rate"), r.key()), "unknown data kind (expected one of " + list + ")");
          }
          c.rate[static_cast<int>(k)] = 1.0 / cx.bandwidth(rate, r.key().c_str(), join(f, "rate"));
        }
      }
    }
  }

  // Every memory device a compute device works from must be reachable from a disk (a data
  // holder, where scene blocks live), or nothing could ever run there.
  std::vector<char> reach(g.memories.size(), 0);
  std::queue<MemId> q;
  for (std::size_t m = 0; m < g.memories.size(); ++m)
    if (g.memories[m].kind == MemoryKind::Disk) {
      reach[m] = 1;
      q.push(static_cast<MemId>(m));
    }
  if (q.empty()) cx.fail("nodes", "no memory device of kind \"disk\": nothing can hold the scene");
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
      cx.fail(mem_field[d.memory], "memory device '" + g.memories[d.memory].name +
                                       "' is unreachable from every disk (add a channel or network), so compute device '" +
                                       d.name + "' could never get data");
  return g;
}

DeviceGraph load_platform(const std::string& path) {
  std::ifstream in = open_input(path, "platform file");
  std::stringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw InputError(path, "", "cannot read platform file");
  return parse_platform(ss.str(), path);
}

}  // namespace rayline
