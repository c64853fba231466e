// Platform files -> device connectivity graph (DCG, Sec. 3.2, Fig. 2). Schema and every
// assumed number: platforms/README.md. In short:
//   * node_types are templates (memory devices, compute devices, intra-node channels);
//   * nodes instantiate a type and may patch it: an entry of the node's memory/compute/
//     channels lists with the name of a template entry is merged into it (RFC 7396 merge
//     patch, null deletes a key), an entry with a new name is added;
//   * networks join one memory device per member node through per-node NIC resources.
// Every problem is an InputError(file, JSON path of the field, message) raised through
// common/json_fields.hpp; one function per section of the format.
#include "sched/io/platform_loader.hpp"

#include <array>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <queue>
#include <set>
#include <sstream>
#include <vector>

#include "common/error.hpp"
#include "common/input_file.hpp"
#include "common/json_fields.hpp"

namespace rayline {

using nlohmann::json;

namespace {

const std::vector<std::string> kDefaultJobTypes = {"RayIntersect", "ShadowIntersect", "GenerateRays", "Shade",
                                                   "Accumulate", "AdditiveCompose", "Compute"};

// Platform files say what a field should hold and what it holds ("expected an object, got
// array"), and list the keys an object allows: a typo ("bandwith") must not silently fall
// back to a default.
constexpr JsonWording kWording{.type_prefix = "expected ",
                               .name_actual_type = true,
                               .unknown_key = "unknown key",
                               .list_allowed_keys = true,
                               .top_level = "(top level)"};

std::string optional_name(const JsonField& object, std::string_view key, const std::string& fallback) {
  const auto v = object.find(key);
  return v ? v->non_empty_string() : fallback;
}

Duplex duplex(const JsonField& object) {
  const std::string d = optional_name(object, "duplex", "full");
  if (d == "half") return Duplex::Half;
  if (d == "full") return Duplex::Full;
  object.at("duplex").fail("expected \"half\" (one medium shared by both directions) or \"full\", got \"" + d + "\"");
}

// One entry of a node's memory/compute/channels/media list after applying the node's
// patches, with the JSON path to report its errors at (the node's own entry when it
// touched it).
struct Entry {
  json value;
  std::string field;
};

std::string entry_name(const JsonField& entry) { return entry.object().at("name").non_empty_string(); }

void merge_or_add(std::vector<Entry>& entries, const JsonField& patch) {
  const std::string name = entry_name(patch);
  for (Entry& e : entries)
    if (e.value.is_object() && e.value.value("name", std::string()) == name) {
      e.value.merge_patch(patch.json());
      e.field = patch.path();
      return;
    }
  entries.push_back({patch.json(), patch.path()});
}

std::vector<Entry> merged_list(const std::optional<JsonField>& type, const JsonField& node, const char* key) {
  std::vector<Entry> out;
  if (const auto list = type ? type->find(key) : std::nullopt)
    for (const JsonField& e : list->elements()) {
      entry_name(e);
      out.push_back({e.json(), e.path()});
    }
  if (const auto patches = node.find(key))
    for (const JsonField& p : patches->elements()) merge_or_add(out, p);
  return out;
}

struct PendingTiming {
  DeviceId device;
  json timing;
  std::string field;
};

// A node while its lists are read: its name, template and the names of its devices.
struct NodeScope {
  JsonField field;
  std::string name;
  NodeId id = kNone;
  std::optional<JsonField> type;  // node_types.<type>, when the node names one
  std::string model_prefix;       // compute models are "<type>.<entry>" ("<node>.<entry>" untyped)
  std::map<std::string, ResourceId> media;
};

std::string list_of(const json& object) {
  std::string list;
  for (auto it = object.begin(); it != object.end(); ++it) list += (list.empty() ? "" : ", ") + it.key();
  return list.empty() ? "none" : list;
}

class PlatformReader {
 public:
  explicit PlatformReader(const JsonInput& input) : in_(input) {}

  DeviceGraph read(const JsonField& root) {
    root.only_keys({"name", "description", "job_types", "node_types", "nodes", "networks", "control_loop", "clients"});
    g_.source_file = in_.file();
    g_.name = root.at("name").non_empty_string();
    if (const auto d = root.find("description"); d && !d->json().is_string()) d->fail("expected a string");
    job_types(root);
    const JsonField types = node_types(root);
    const JsonField nodes = root.at("nodes").array();
    if (nodes.size() == 0) nodes.fail("a platform needs at least one node");
    for (const JsonField& node : nodes.elements()) read_node(node, types);
    if (const auto nets = root.find("networks"))
      for (const JsonField& net : nets->elements()) network(net);
    if (const auto cl = root.find("control_loop")) control_loop(*cl);
    if (const auto c = root.find("clients")) clients(*c);
    g_.finalize();
    for (const PendingTiming& pt : timings_) timing(pt);
    check_reachable();
    return std::move(g_);
  }

 private:
  // "clients": "NODE.MEMORY", the host memory where path-tracing clients keep their
  // framebuffers (the paper ran its clients on a node of their own).
  void clients(const JsonField& f) {
    const std::string name = f.non_empty_string();
    const MemId m = g_.find_memory(name);
    if (m == kNone) f.fail("no memory device named '" + name + "' (expected NODE.MEMORY, e.g. \"K.ram\")");
    if (g_.memories[static_cast<std::size_t>(m)].kind != MemoryKind::Host)
      f.fail("'" + name + "' is not a host memory device: clients keep their framebuffers in host memory");
    g_.client_memory = m;
  }

  // "control_loop": {"per_job": DURATION, "per_exec_second": NUMBER >= 0, "wake": DURATION,
  // "per_camera_ray": DURATION, "pickup": DURATION} (ControlLoop).
  void control_loop(const JsonField& f) {
    f.object().only_keys({"per_job", "per_exec_second", "wake", "per_camera_ray", "pickup", "description"});
    if (const auto p = f.find("pickup")) {
      g_.loop.pickup = p->quantity(JsonUnit::duration);
      if (!(g_.loop.pickup >= 0 && g_.loop.pickup < 1)) p->fail("expected a duration from 0 to 1 s");
    }
    if (const auto p = f.find("per_camera_ray")) {
      g_.loop.per_camera_ray = p->quantity(JsonUnit::duration);
      if (!(g_.loop.per_camera_ray >= 0 && g_.loop.per_camera_ray < 1)) p->fail("expected a duration from 0 to 1 s");
    }
    if (const auto p = f.find("wake")) {
      g_.loop.wake = p->quantity(JsonUnit::duration);
      if (!(g_.loop.wake >= 0)) p->fail("expected a duration of at least 0");
    }
    if (const auto p = f.find("per_job")) {
      g_.loop.per_job = p->quantity(JsonUnit::duration);
      if (!(g_.loop.per_job >= 0)) p->fail("expected a duration of at least 0");
    }
    if (const auto p = f.find("per_exec_second")) {
      g_.loop.per_exec_second = p->number();
      if (!(g_.loop.per_exec_second >= 0 && g_.loop.per_exec_second < 1e6)) p->fail("expected a number from 0");
    }
  }

  // Job types (JobTypeId order). Default: the path-tracing job graph of Fig. 3 + Compute.
  void job_types(const JsonField& root) {
    const auto jt = root.find("job_types");
    if (!jt) {
      g_.job_types = kDefaultJobTypes;
      return;
    }
    if (jt->array().size() == 0) jt->fail("expected at least one job type");
    for (const JsonField& t : jt->elements()) {
      if (!t.json().is_string() || t.json().get_ref<const std::string&>().empty())
        t.fail("expected a non-empty string");
      const std::string name = t.json().get<std::string>();
      if (g_.job_type(name) != kNone) t.fail("duplicate job type '" + name + "'");
      g_.job_types.push_back(name);
    }
  }

  JsonField node_types(const JsonField& root) {
    static const json none = json::object();
    const JsonField types = root.has("node_types") ? root.at("node_types") : in_.field(none, "node_types");
    if (!types.json().is_object()) types.fail("expected an object: type name -> node template");
    for (const auto& t : types.members()) t.field.only_keys({"description", "memory", "compute", "channels", "media"});
    return types;
  }

  void read_node(const JsonField& node, const JsonField& types) {
    node.only_keys({"name", "type", "description", "memory", "compute", "channels", "media"});
    NodeScope n{node, node.at("name").non_empty_string(), static_cast<NodeId>(g_.nodes.size()), std::nullopt, "", {}};
    if (n.name.find('.') != std::string::npos) node.at("name").fail("node names may not contain '.'");
    if (g_.find_node(n.name) != kNone) node.at("name").fail("duplicate node name '" + n.name + "'");
    n.model_prefix = n.name;
    if (node.has("type")) {
      const JsonField type = node.at("type");
      const std::string tname = type.non_empty_string();
      if (!types.has(tname)) type.fail("unknown node type '" + tname + "' (node_types: " + list_of(types.json()) + ")");
      n.type = types.at(tname);
      n.model_prefix = tname;
    }
    g_.nodes.push_back({n.name, {}, {}});
    memories(n);
    for (const Entry& e : merged_list(n.type, node, "compute")) compute(n, in_.field(e.value, e.field));
    for (const Entry& e : merged_list(n.type, node, "media")) medium(n, in_.field(e.value, e.field));
    std::set<std::string> channel_names;
    for (const Entry& e : merged_list(n.type, node, "channels"))
      channel(n, in_.field(e.value, e.field), channel_names);
  }

  // Memory devices: vertices of the DCG.
  void memories(const NodeScope& n) {
    const auto mems = merged_list(n.type, n.field, "memory");
    if (mems.empty()) (n.type ? *n.type : n.field).fail_at("memory", "a node needs at least one memory device");
    auto& local = node_mem_[n.name];
    for (const Entry& e : mems) {
      const JsonField f = in_.field(e.value, e.field);
      f.only_keys({"name", "kind", "capacity", "description"});
      const std::string local_name = f.at("name").non_empty_string();
      if (local.count(local_name)) f.at("name").fail("duplicate memory device name '" + local_name + "'");
      MemoryDevice m;
      m.name = n.name + "." + local_name;
      m.kind = memory_kind(f.at("kind"));
      const double cap = f.at("capacity").quantity(JsonUnit::bytes);
      if (!(cap > 0)) f.at("capacity").fail("must be > 0");
      if (cap > 9.2e18) f.at("capacity").fail("too large");
      m.capacity = static_cast<Bytes>(cap);
      m.node = n.id;
      local[local_name] = static_cast<MemId>(g_.memories.size());
      g_.nodes.back().memories.push_back(static_cast<MemId>(g_.memories.size()));
      g_.memories.push_back(std::move(m));
      mem_field_.push_back(e.field);
    }
  }

  static MemoryKind memory_kind(const JsonField& f) {
    const std::string kind = f.non_empty_string();
    if (kind == "disk") return MemoryKind::Disk;
    if (kind == "host") return MemoryKind::Host;
    if (kind == "gpu") return MemoryKind::Gpu;
    f.fail("unknown memory kind '" + kind + "' (expected disk, host or gpu)");
  }

  static ComputeKind compute_kind(const JsonField& f) {
    const std::string kind = f.non_empty_string();
    if (kind == "cpu") return ComputeKind::Cpu;
    if (kind == "gpu") return ComputeKind::Gpu;
    f.fail("unknown compute kind '" + kind + "' (expected cpu or gpu)");
  }

  // A memory device of the node, by its local name ("ram").
  MemId local_memory(const NodeScope& n, const JsonField& f, const std::string& name) {
    const auto& local = node_mem_[n.name];
    const auto it = local.find(name);
    if (it == local.end()) f.fail("unknown memory device '" + name + "' on node '" + n.name + "'");
    return it->second;
  }

  // Compute devices: each attached to exactly one memory device (Sec. 3.2).
  void compute(const NodeScope& n, const JsonField& f) {
    f.only_keys({"name", "kind", "count", "memory", "timing", "description"});
    const std::string cname = f.at("name").non_empty_string();
    const ComputeKind kind = compute_kind(f.at("kind"));
    const int count = f.has("count") ? static_cast<int>(f.at("count").integer(1, 65536)) : 1;
    if (!f.has("memory"))
      f.fail_at("memory", "missing: every compute device is attached to a memory device");
    const MemId mem = local_memory(n, f.at("memory"), f.at("memory").non_empty_string());
    const auto timing = f.find("timing");
    if (timing && !timing->json().is_object()) timing->fail("expected an object: job type -> {setup, rate}");
    for (int k = 0; k < count; ++k) {
      ComputeDevice d;
      d.name = n.name + "." + (count > 1 ? cname + std::to_string(k) : cname);  // "A0.cpu3"
      if (g_.find_compute(d.name) != kNone) f.at("name").fail("duplicate compute device name '" + d.name + "'");
      d.model = n.model_prefix + "." + cname;
      d.kind = kind;
      d.memory = mem;
      d.node = n.id;
      const auto id = static_cast<DeviceId>(g_.computes.size());
      g_.nodes.back().computes.push_back(id);
      g_.computes.push_back(std::move(d));
      if (timing) timings_.push_back({id, timing->json(), timing->path()});
    }
  }

  // Shared media inside a node (e.g. one PCIe root complex behind several GPUs): one
  // resource each; every channel that names it in "media" also occupies it, in both
  // directions, so those channels contend (DCG contention, device_graph.hpp).
  void medium(NodeScope& n, const JsonField& f) {
    f.only_keys({"name", "bandwidth", "description"});
    const std::string mname = f.at("name").non_empty_string();
    if (n.media.count(mname)) f.at("name").fail("duplicate medium '" + mname + "'");
    g_.resources.push_back({n.name + "." + mname, f.at("bandwidth").quantity(JsonUnit::bandwidth)});
    n.media[mname] = static_cast<ResourceId>(g_.resources.size() - 1);
  }

  std::vector<ResourceId> channel_media(const NodeScope& n, const JsonField& f) {
    std::vector<ResourceId> shared;
    if (!f.has("media")) return shared;
    for (const JsonField& m : f.at("media").array().elements()) {
      if (!m.json().is_string()) m.fail("expected the name of a medium");
      const auto it = n.media.find(m.json().get<std::string>());
      if (it == n.media.end()) m.fail("unknown medium '" + m.json().get<std::string>() + "' on node '" + n.name + "'");
      shared.push_back(it->second);
    }
    return shared;
  }

  std::array<MemId, 2> channel_ends(const NodeScope& n, const JsonField& f) {
    const JsonField between = f.at("between").array();
    if (between.size() != 2) between.fail("expected two memory device names, e.g. [\"disk\", \"ram\"]");
    std::array<MemId, 2> ends{};
    for (std::size_t k = 0; k < 2; ++k) {
      const JsonField end = between.element(k);
      if (!end.json().is_string()) end.fail("expected a memory device name");
      ends[k] = local_memory(n, end, end.json().get<std::string>());
    }
    if (ends[0] == ends[1]) between.fail("a channel joins two different memory devices");
    return ends;
  }

  // Intra-node channels: a half-duplex medium (SATA) is one resource for both
  // directions; a full-duplex one (PCIe) one resource per direction.
  void channel(const NodeScope& n, const JsonField& f, std::set<std::string>& names) {
    f.only_keys({"name", "kind", "between", "duplex", "latency", "bandwidth", "media", "cpu_contention", "description"});
    const std::string cname = f.at("name").non_empty_string();
    const std::vector<ResourceId> shared = channel_media(n, f);
    if (!names.insert(cname).second) f.at("name").fail("duplicate channel name '" + cname + "'");
    const std::array<MemId, 2> ends = channel_ends(n, f);
    const Duplex dup = duplex(f);
    Channel c;
    c.latency = f.at("latency").quantity(JsonUnit::duration);
    c.bandwidth = f.at("bandwidth").quantity(JsonUnit::bandwidth);
    c.kind = optional_name(f, "kind", cname);
    // "cpu_contention": {"transfer": NUMBER >= 0, "exec": NUMBER >= 0} (Channel).
    if (const auto p = f.find("cpu_contention")) {
      p->object().only_keys({"transfer", "exec"});
      for (const auto& [key, to] : {std::pair{"transfer", &c.cpu_contention}, std::pair{"exec", &c.exec_contention}})
        if (const auto q = p->find(key)) {
          *to = q->number();
          if (!(*to >= 0)) q->fail("expected a number of at least 0");
        }
    }
    const std::string base = n.name + "." + cname;
    std::array<ResourceId, 2> res{};
    if (dup == Duplex::Half) {
      res[0] = res[1] = add_resource(base, c.bandwidth);
    } else {
      res[0] = add_resource(base + ".fwd", c.bandwidth);
      res[1] = add_resource(base + ".rev", c.bandwidth);
    }
    for (int dir = 0; dir < 2; ++dir) {
      const MemId a = ends[dir], b = ends[1 - dir];
      c.name = base + ":" + g_.memories[a].name.substr(n.name.size() + 1) + "->" +
               g_.memories[b].name.substr(n.name.size() + 1);  // "A0.sata:disk->ram"
      c.from = a;
      c.to = b;
      c.resources = {res[dir]};
      c.resources.insert(c.resources.end(), shared.begin(), shared.end());
      g_.channels.push_back(c);
    }
  }

  ResourceId add_resource(std::string name, double bandwidth) {
    g_.resources.push_back({std::move(name), bandwidth});
    return static_cast<ResourceId>(g_.resources.size() - 1);
  }

  // A network member: the node's memory device on the network, its NIC resources and
  // its rack (kNone without racks).
  struct Member {
    std::string node;
    MemId mem;
    double bw;
    ResourceId out, in;
    std::int32_t rack = kNone;
  };

  Member member(const JsonField& f, const std::string& network, Duplex dup, std::optional<double> default_bw,
                const std::map<std::string, std::int32_t>& racks, std::set<std::string>& seen) {
    f.only_keys({"node", "memory", "bandwidth", "rack"});
    const std::string node = f.at("node").non_empty_string();
    if (!node_mem_.count(node)) f.at("node").fail("unknown node '" + node + "'");
    if (!seen.insert(node).second) f.at("node").fail("node '" + node + "' is listed twice");
    const std::string mem = optional_name(f, "memory", "ram");
    if (!node_mem_[node].count(mem))
      f.fail_at("memory", "unknown memory device '" + mem + "' on node '" + node + "'");
    if (!f.has("bandwidth") && !default_bw)
      f.fail_at("bandwidth", "missing (NIC speed; or give the network a bandwidth)");
    std::int32_t rack = kNone;
    if (racks.empty()) {
      if (f.has("rack")) f.at("rack").fail("the network lists no racks");
    } else {
      if (!f.has("rack")) f.fail_at("rack", "missing (the network has racks: every member names one)");
      const std::string r = f.at("rack").non_empty_string();
      const auto it = racks.find(r);
      if (it == racks.end()) f.at("rack").fail("unknown rack '" + r + "'");
      rack = it->second;
    }
    const double bw = f.has("bandwidth") ? f.at("bandwidth").quantity(JsonUnit::bandwidth) : *default_bw;
    const std::string base = node + "." + network;
    if (dup == Duplex::Full) {
      const ResourceId out = add_resource(base + ".out", bw);
      return {node, node_mem_[node][mem], bw, out, add_resource(base + ".in", bw), rack};
    }
    const ResourceId nic = add_resource(base + ".nic", bw);
    return {node, node_mem_[node][mem], bw, nic, nic, rack};
  }

  // Networks: a switched LAN; every member contributes one memory device and its NIC.
  // A channel joins every ordered pair of members and occupies the sender's outgoing and
  // the receiver's incoming NIC (one shared NIC if half duplex); between racks also the
  // sender rack's uplink, the backbone and the receiver rack's downlink; without racks
  // the backbone, if there is one. Its bandwidth is the least of those resources' and its
  // latency the network's, plus the backbone's when it crosses it. A rack switch (or the
  // switch of a network without backbone) is non-blocking.
  void network(const JsonField& f) {
    f.only_keys({"name", "kind", "latency", "duplex", "bandwidth", "members", "backbone", "racks", "description"});
    const std::string name = f.at("name").non_empty_string();
    if (!net_names_.insert(name).second) f.at("name").fail("duplicate network name '" + name + "'");
    const std::string kind = optional_name(f, "kind", "lan");
    const double lat = f.at("latency").quantity(JsonUnit::duration);
    const Duplex dup = duplex(f);
    std::optional<double> default_bw;
    if (f.has("bandwidth")) default_bw = f.at("bandwidth").quantity(JsonUnit::bandwidth);
    Network net;
    net.name = name;
    const auto net_id = static_cast<std::int32_t>(g_.networks.size());
    double backbone_lat = 0;
    if (const auto bb = f.find("backbone")) {
      bb->object().only_keys({"bandwidth", "latency"});
      net.backbone = add_resource(name + ".backbone", bb->at("bandwidth").quantity(JsonUnit::bandwidth));
      if (bb->has("latency")) backbone_lat = bb->at("latency").quantity(JsonUnit::duration);
    }
    // Racks: names first (members refer to them), uplinks once the members are known.
    std::map<std::string, std::int32_t> rack_ids;
    std::vector<JsonField> rack_fields;
    if (const auto racks = f.find("racks")) {
      const JsonField list = racks->array();
      if (list.size() == 0) list.fail("a network with racks lists at least one");
      for (const JsonField& r : list.elements()) {
        r.only_keys({"name", "uplink", "oversubscription"});
        const std::string rn = r.at("name").non_empty_string();
        if (!rack_ids.emplace(rn, static_cast<std::int32_t>(rack_fields.size())).second)
          r.at("name").fail("duplicate rack name '" + rn + "'");
        if (r.has("uplink") == r.has("oversubscription"))
          r.fail_at("uplink", "give either \"uplink\" (a bandwidth) or \"oversubscription\" (the rack's NIC total / uplink)");
        rack_fields.push_back(r);
      }
    }
    const JsonField members = f.at("members").array();
    if (members.size() < 2) members.fail("a network joins at least two nodes");
    std::vector<Member> ms;
    std::set<std::string> seen;
    for (const JsonField& m : members.elements()) ms.push_back(member(m, name, dup, default_bw, rack_ids, seen));
    for (std::size_t r = 0; r < rack_fields.size(); ++r) {
      const JsonField& rf = rack_fields[r];
      double nics = 0;
      for (const Member& m : ms)
        if (m.rack == static_cast<std::int32_t>(r)) nics += m.bw;
      const std::string rn = rf.at("name").non_empty_string();
      if (nics == 0) rf.at("name").fail("rack '" + rn + "' has no member");
      double bw;
      if (rf.has("uplink")) {
        bw = rf.at("uplink").quantity(JsonUnit::bandwidth);
      } else {
        const JsonField x = rf.at("oversubscription");
        if (!x.json().is_number() || !(x.json().get<double>() > 0)) x.fail("expected a number > 0 (e.g. 4 for 4:1)");
        bw = nics / x.json().get<double>();
      }
      Rack rack{rn, kNone, kNone};
      const std::string base = name + "." + rn;
      if (dup == Duplex::Full) {
        rack.up = add_resource(base + ".up", bw);
        rack.down = add_resource(base + ".down", bw);
      } else {
        rack.up = rack.down = add_resource(base + ".uplink", bw);
      }
      net.racks.push_back(std::move(rack));
    }
    for (const Member& a : ms) net.members.push_back({g_.memories[static_cast<std::size_t>(a.mem)].node, a.mem, a.out, a.in, a.rack});
    for (std::size_t a = 0; a < ms.size(); ++a)
      for (std::size_t b = 0; b < ms.size(); ++b) {
        if (a == b) continue;
        Channel c;
        c.name = name + ":" + ms[a].node + "->" + ms[b].node;  // "lan:A0->B"
        c.kind = kind;
        c.from = ms[a].mem;
        c.to = ms[b].mem;
        c.network = net_id;
        c.resources = net.route(a, b);
        c.latency = lat + (net.crosses_backbone(a, b) ? backbone_lat : 0);
        c.bandwidth = kNever;
        for (ResourceId r : c.resources) c.bandwidth = std::min(c.bandwidth, g_.resources[r].bandwidth);
        g_.channels.push_back(std::move(c));
      }
    g_.networks.push_back(std::move(net));
  }

  // Eq. 2 coefficients. A throughput X B/s of an input kind becomes rate = 1/X s per byte;
  // a job type a device does not list is unsupported there.
  void timing(const PendingTiming& pt) {
    for (const auto& [job_type, f] : in_.field(pt.timing, pt.field).members()) {
      const JobTypeId j = g_.job_type(job_type);
      if (j == kNone) f.fail("unknown job type '" + job_type + "' (not in job_types)");
      f.only_keys({"setup", "rate"});
      if (f.json().empty()) f.fail("expected \"setup\" and/or \"rate\"");
      ExecCoefficients& c = g_.timing.at(pt.device, j);
      c = ExecCoefficients{};
      c.supported = true;
      c.setup = f.has("setup") ? f.at("setup").quantity(JsonUnit::duration) : 0;
      if (f.has("rate")) rates(f.at("rate"), c);
    }
  }

  static void rates(const JsonField& rate, ExecCoefficients& c) {
    if (!rate.json().is_object())
      rate.fail("expected an object: data kind -> throughput, e.g. {\"RayQueue\": \"640MB/s\"}");
    for (const auto& [name, r] : rate.members()) {
      DataKind k;
      if (!parse_data_kind(name, k)) {
        std::string list;
        for (auto kind : kDataKindNames) list += (list.empty() ? "" : ", ") + std::string(kind);
        r.fail("unknown data kind (expected one of " + list + ")");
      }
      c.rate[static_cast<int>(k)] = 1.0 / r.quantity(JsonUnit::bandwidth);
    }
  }

  // Every memory device a compute device works from must be reachable from a disk (a data
  // holder, where scene blocks live), or nothing could ever run there.
  void check_reachable() const {
    std::vector<char> reach(g_.memories.size(), 0);
    std::queue<MemId> q;
    for (std::size_t m = 0; m < g_.memories.size(); ++m)
      if (g_.memories[m].kind == MemoryKind::Disk) {
        reach[m] = 1;
        q.push(static_cast<MemId>(m));
      }
    if (q.empty()) in_.fail("nodes", "no memory device of kind \"disk\": nothing can hold the scene");
    for (; !q.empty(); q.pop())
      for (ChannelId c : g_.out_channels(q.front()))
        if (!reach[g_.channels[c].to]) {
          reach[g_.channels[c].to] = 1;
          q.push(g_.channels[c].to);
        }
    for (const ComputeDevice& d : g_.computes)
      if (!reach[d.memory])
        in_.fail(mem_field_[d.memory], "memory device '" + g_.memories[d.memory].name +
                                           "' is unreachable from every disk (add a channel or network), so compute "
                                           "device '" + d.name + "' could never get data");
  }

  const JsonInput& in_;
  DeviceGraph g_;
  std::vector<PendingTiming> timings_;
  std::map<std::string, std::map<std::string, MemId>> node_mem_;  // node -> local memory name -> id
  std::vector<std::string> mem_field_;                            // MemId -> JSON path (for errors)
  std::set<std::string> net_names_;
};

}  // namespace

DeviceGraph parse_platform(std::string_view text, const std::string& file) {
  const JsonInput input(file, kWording);
  const json doc = input.parse(text, {.reject_duplicate_keys = true, .drop_exception_tag = true});
  return PlatformReader(input).read(input.field(doc, ""));
}

DeviceGraph load_platform(const std::string& path) {
  std::ifstream in = open_input(path, "platform file");
  std::stringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw InputError(path, "", "cannot read platform file");
  return parse_platform(ss.str(), path);
}

}  // namespace rayline
