// SgPlatform: the S4U adapter. Every SimGrid call of the platform builder lives here.
#include "sim/sg_platform.hpp"

#include <simgrid/kernel/Timer.hpp>
#include <simgrid/s4u/Activity.hpp>
#include <simgrid/s4u/Comm.hpp>
#include <simgrid/s4u/Engine.hpp>
#include <simgrid/s4u/Exec.hpp>
#include <simgrid/s4u/Host.hpp>
#include <simgrid/s4u/Link.hpp>
#include <simgrid/s4u/NetZone.hpp>
#include <xbt/log.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>

#include "common/error.hpp"
#include "sim/sg_platform_internal.hpp"

namespace sg4 = simgrid::s4u;

namespace rayline::sim {

namespace {

bool g_engine_created = false;  // SimGrid's engine is a process-wide singleton

// The exact-timing recipe (sim/README.md, Sec. 3): no latency/bandwidth factors,
// no 5% cross-traffic, no TCP window bound. Must precede the first zone.
void configure_engine(const SgOptions& options) {
  xbt_log_control_set(options.log_control.c_str());
  sg4::Engine::set_config("network/model:CM02");
  sg4::Engine::set_config("network/crosstraffic:0");
  sg4::Engine::set_config("network/TCP-gamma:1e30");
  for (const std::string& kv : options.config) sg4::Engine::set_config(kv);
}

sg4::Link* make_link(sg4::NetZone* zone, const std::string& name, double bandwidth) {
  sg4::Link* link = zone->create_link(name, bandwidth);
  link->set_latency(0.0);
  link->set_sharing_policy(sg4::Link::SharingPolicy::SHARED);
  return link;
}

// Names SimGrid will see must be unique across hosts; links get a kind prefix.
void check_unique_host_names(const DeviceGraph& g) {
  std::set<std::string> seen;
  auto claim = [&](const std::string& name, const std::string& field) {
    if (name.empty()) throw InputError(g.source_file, field, "empty name");
    if (!seen.insert(name).second) throw InputError(g.source_file, field, "name '" + name + "' is used twice");
  };
  for (const MemoryDevice& m : g.memories) claim(m.name, "memories[" + m.name + "].name");
  for (const ComputeDevice& d : g.computes) claim(d.name, "computes[" + d.name + "].name");
}

// SimGrid can reproduce Eq. 1 only if no resource of a channel is slower than the channel.
void check_bandwidths(const DeviceGraph& g) {
  for (const Resource& r : g.resources)
    if (!(r.bandwidth > 0) || !std::isfinite(r.bandwidth))
      throw InputError(g.source_file, "resources[" + r.name + "].bandwidth", "must be a finite value > 0");
  for (const Channel& c : g.channels) {
    if (!std::isfinite(c.bandwidth))
      throw InputError(g.source_file, "channels[" + c.name + "].bandwidth", "must be finite");
    for (ResourceId r : c.resources) {
      const Resource& res = g.resources[r];
      if (c.bandwidth > res.bandwidth * (1 + 1e-12))
        throw InputError(g.source_file, "channels[" + c.name + "].bandwidth",
                         "exceeds the bandwidth of its resource '" + res.name +
                             "'; a lone transfer could not take latency + bytes/bandwidth");
    }
  }
}

// A channel's resources in its order, a resource listed twice used once.
std::vector<ResourceId> distinct_resources(const Channel& c) {
  std::vector<ResourceId> res;
  for (ResourceId r : c.resources)
    if (std::find(res.begin(), res.end(), r) == res.end()) res.push_back(r);
  return res;
}

}  // namespace

// ---------------------------------------------------------------------------------------
// Construction: engine, hosts, links, routes, signals.

SgPlatform::SgPlatform(const DeviceGraph& graph, const SgOptions& options) : impl_(std::make_unique<Impl>()) {
  if (g_engine_created)
    throw std::logic_error("SgPlatform: SimGrid's engine is a process-wide singleton; one SgPlatform per process");
  Impl& m = *impl_;
  m.graph = graph;
  m.graph.finalize();
  m.exclusive_execs = options.exclusive_execs;
  const DeviceGraph& g = m.graph;
  check_unique_host_names(g);
  check_bandwidths(g);

  g_engine_created = true;
  m.engine = std::make_unique<sg4::Engine>("rayline");
  configure_engine(options);

  // Zones, linear in the platform's size (sim/README.md, "Platform model"):
  //  * point-to-point channels (a node's own, or any a test builds by hand): one full zone
  //    per connected group of memory devices, one explicit route per channel;
  //  * a network: a star zone with one relay host per member (its racks: star zones
  //    inside it, each behind a router host). SimGrid composes a route from the members'
  //    NIC links, the racks' uplinks and the backbone, so a network of N members holds
  //    O(N) links and routes instead of one per ordered pair;
  //  * compute hosts: an empty zone (they never communicate).
  // Every route stays inside one zone; the root holds none (a zone with children needs
  // gateways for every route it holds).
  sg4::NetZone* root = sg4::create_empty_zone("rayline");
  sg4::NetZone* cpu = sg4::create_empty_zone("rayline.compute");
  cpu->set_parent(root);

  // Groups of memory devices joined by point-to-point channels (union-find).
  std::vector<MemId> group(g.memories.size());
  for (std::size_t i = 0; i < group.size(); ++i) group[i] = static_cast<MemId>(i);
  auto find = [&](MemId x) {
    while (group[x] != x) x = group[x] = group[group[x]];
    return x;
  };
  for (const Channel& c : g.channels)
    if (c.network == kNone) group[find(c.from)] = find(c.to);
  std::vector<sg4::NetZone*> group_zone(g.memories.size(), nullptr);
  std::vector<sg4::NetZone*> zones{cpu};
  for (std::size_t i = 0; i < g.memories.size(); ++i) {
    sg4::NetZone*& z = group_zone[find(static_cast<MemId>(i))];
    if (!z) {
      z = sg4::create_full_zone("rayline.mem." + g.memories[i].name);
      z->set_parent(root);
      zones.push_back(z);
    }
    m.memory_hosts.push_back(z->create_host(g.memories[i].name, 1.0));
  }
  for (const ComputeDevice& cd : g.computes) m.compute_hosts.push_back(cpu->create_host(cd.name, 1.0));

  // Resource links live in the zone of their first user (a link may serve routes of any
  // zone; only its name must be unique).
  m.resource_links.assign(g.resources.size(), nullptr);
  auto resource_link = [&](ResourceId r, sg4::NetZone* z) {
    if (!m.resource_links[r])
      m.resource_links[r] = make_link(z, "res[" + std::to_string(r) + "]:" + g.resources[r].name, g.resources[r].bandwidth);
    return m.resource_links[r];
  };

  // A channel needs its own link only when it is slower than its slowest resource: every
  // flow on it crosses all of them, so otherwise that link's constraint is implied.
  m.channel_links.assign(g.channels.size(), nullptr);
  m.channel_route.resize(g.channels.size());
  m.channel_src.resize(g.channels.size());
  m.channel_dst.resize(g.channels.size());
  auto needs_own_link = [&](const Channel& c) {
    if (c.cpu_contention > 0) return true;  // its bandwidth moves with the CPU threads (set_channel_bandwidth)
    double slowest = std::numeric_limits<double>::infinity();
    for (ResourceId r : c.resources) slowest = std::min(slowest, g.resources[r].bandwidth);
    return c.bandwidth < slowest * (1 - 1e-12);
  };
  auto own_link = [&](ChannelId i, sg4::NetZone* z) -> sg4::Link* {
    const Channel& c = g.channels[i];
    if (!needs_own_link(c)) return nullptr;
    sg4::Link* own = make_link(z, "chan[" + std::to_string(i) + "]:" + c.name, c.bandwidth);
    m.channel_links[i] = own;
    m.channel_route[i].push_back(m.channel_link_index(i));
    return own;
  };

  std::map<std::pair<MemId, MemId>, int> pair_uses;
  for (std::size_t i = 0; i < g.channels.size(); ++i) {
    const Channel& c = g.channels[i];
    if (c.network != kNone) continue;
    sg4::NetZone* z = group_zone[find(c.from)];
    std::vector<sg4::LinkInRoute> route;
    if (sg4::Link* own = own_link(static_cast<ChannelId>(i), z)) route.emplace_back(own);
    for (ResourceId r : distinct_resources(c)) {
      route.emplace_back(resource_link(r, z));
      m.channel_route[i].push_back(m.resource_link_index(r));
    }
    sg4::Host* src = m.memory_hosts[c.from];
    if (pair_uses[{c.from, c.to}]++ > 0)  // a second channel between the same pair
      src = z->create_host(g.memories[c.from].name + "~relay" + std::to_string(i), 1.0);
    sg4::Host* dst = m.memory_hosts[c.to];
    z->add_route(src->get_netpoint(), dst->get_netpoint(), nullptr, nullptr, route, /*symmetrical=*/false);
    m.channel_src[i] = src;
    m.channel_dst[i] = dst;
  }

  // Networks. A member's relay sends and receives its traffic: up through its NIC-out
  // (then, without racks, the backbone), down through its NIC-in; between racks, a rack
  // zone goes up through its uplink and the backbone and down through its downlink.
  std::vector<std::vector<sg4::Host*>> relay(g.networks.size());
  std::vector<std::vector<std::int32_t>> member_at(g.networks.size());  // [network][MemId]: member index
  for (std::size_t n = 0; n < g.networks.size(); ++n) {
    const Network& net = g.networks[n];
    member_at[n].assign(g.memories.size(), kNone);
    sg4::NetZone* nz = sg4::create_star_zone("rayline.net." + net.name);
    nz->set_parent(root);
    zones.push_back(nz);
    auto links = [](std::initializer_list<sg4::Link*> ls) {
      std::vector<sg4::LinkInRoute> r;
      for (sg4::Link* l : ls)
        if (l) r.emplace_back(l);
      return r;
    };
    sg4::Link* backbone = net.backbone == kNone ? nullptr : resource_link(net.backbone, nz);
    std::vector<sg4::NetZone*> rack_zone;
    std::vector<sg4::Host*> router;
    for (std::size_t r = 0; r < net.racks.size(); ++r) {
      sg4::NetZone* rz = sg4::create_star_zone("rayline.net." + net.name + "." + net.racks[r].name);
      rz->set_parent(nz);
      zones.push_back(rz);
      sg4::Host* gw = rz->create_host(net.name + "." + net.racks[r].name + "~router", 1.0);
      nz->add_route(rz->get_netpoint(), nullptr, gw->get_netpoint(), nullptr,
                    links({resource_link(net.racks[r].up, nz), backbone}), false);
      nz->add_route(nullptr, rz->get_netpoint(), nullptr, gw->get_netpoint(),
                    links({resource_link(net.racks[r].down, nz)}), false);
      rack_zone.push_back(rz);
      router.push_back(gw);
    }
    for (const NetworkMember& mb : net.members) {
      sg4::NetZone* z = mb.rack == kNone ? nz : rack_zone[static_cast<std::size_t>(mb.rack)];
      sg4::Host* h = z->create_host(g.memories[mb.memory].name + "~" + net.name, 1.0);
      sg4::Link* bb = mb.rack == kNone ? backbone : nullptr;
      z->add_route(h->get_netpoint(), nullptr, nullptr, nullptr, links({resource_link(mb.out, z), bb}), false);
      z->add_route(nullptr, h->get_netpoint(), nullptr, nullptr, links({resource_link(mb.in, z)}), false);
      relay[n].push_back(h);
      member_at[n][static_cast<std::size_t>(mb.memory)] = static_cast<std::int32_t>(relay[n].size() - 1);
    }
  }
  for (std::size_t i = 0; i < g.channels.size(); ++i) {
    const Channel& c = g.channels[i];
    if (c.network == kNone) continue;
    const Network& net = g.networks[static_cast<std::size_t>(c.network)];
    auto member_of = [&](MemId mem) {
      const auto& at = member_at[static_cast<std::size_t>(c.network)];
      if (at[static_cast<std::size_t>(mem)] == kNone)
        throw InputError(g.source_file, "channels[" + c.name + "]",
                         "joins a memory device that is no member of network '" + net.name + "'");
      return static_cast<std::size_t>(at[static_cast<std::size_t>(mem)]);
    };
    const std::size_t a = member_of(c.from), b = member_of(c.to);
    // The channel's resources must be exactly the route SimGrid composes (checked, as a
    // hand-built graph could say otherwise).
    if (c.resources != net.route(a, b))
      throw InputError(g.source_file, "channels[" + c.name + "].resources",
                       "differ from the route of network '" + net.name + "' between its two members");
    if (needs_own_link(c))
      throw InputError(g.source_file, "channels[" + c.name + "].bandwidth",
                       "is below its slowest resource; a network channel runs at its slowest resource's bandwidth");
    for (ResourceId r : distinct_resources(c)) m.channel_route[i].push_back(m.resource_link_index(r));
    m.channel_src[i] = relay[static_cast<std::size_t>(c.network)][a];
    m.channel_dst[i] = relay[static_cast<std::size_t>(c.network)][b];
  }
  // Resources no channel uses still get a link (their byte counter reads 0).
  for (std::size_t r = 0; r < g.resources.size(); ++r) resource_link(static_cast<ResourceId>(r), cpu);
  for (auto it = zones.rbegin(); it != zones.rend(); ++it) (*it)->seal();
  root->seal();

  const std::size_t nlinks = g.resources.size() + g.channels.size();
  m.link_bytes.assign(nlinks, 0.0);
  m.channel_done_bytes.assign(g.channels.size(), 0.0);
  m.device_work_s.assign(g.computes.size(), 0.0);
  m.device_active.assign(g.computes.size(), 0);
  m.device_slowdown.assign(g.computes.size(), 1.0);
  m.device_exec.assign(g.computes.size(), 0);
  m.device_since.assign(g.computes.size(), 0.0);

  Impl* self = &m;
  sg4::Activity::on_completion_cb([self](const sg4::Activity& a) {
    auto it = self->by_activity.find(&a);
    if (it == self->by_activity.end()) return;  // not ours
    const SgActivityId id = it->second;
    self->by_activity.erase(it);
    const bool ok = a.get_state() == sg4::Activity::State::FINISHED;
    self->complete(id, ok ? a.get_finish_time() : sg4::Engine::get_clock(), ok);
  });
  sg4::Engine::on_time_advance_cb([self](double delta) { self->on_time_advance(delta); });
}

SgPlatform::~SgPlatform() {
  // An activity still running when the engine dies leaves SimGrid callbacks holding kernel
  // objects that crash at process exit: cancel everything and let the engine settle first.
  try {
    if (!impl_->pending.empty()) {
      impl_->stop_all();
      impl_->engine->run();
    }
  } catch (...) {
  }
  impl_->graveyard.clear();
}

// ---------------------------------------------------------------------------------------
// Impl: bookkeeping shared by the signals and the start_* calls.

// A compute host runs at 1 flop/s on one core: it is fully loaded while at least one exec
// runs on it, so its busy time is the union of those intervals, summed as they close.
void SgPlatform::Impl::mark_device(DeviceId d, int delta_count) {
  const int before = device_active[d];
  device_active[d] += delta_count;
  if (before == 0 && device_active[d] > 0) device_since[d] = sg4::Engine::get_clock();
  if (before > 0 && device_active[d] == 0) device_work_s[d] += sg4::Engine::get_clock() - device_since[d];
}

// Every flow crosses each link of its route with all its bytes: a link's integral of
// usage is the bytes of the flows that crossed it, added as each flow ends (or is
// cancelled, with what it had sent), in O(route) per transfer rather than per time step.
void SgPlatform::Impl::add_route_bytes(ChannelId c, double bytes) {
  for (std::int32_t l : channel_route[c]) link_bytes[l] += bytes;
  if (!channel_links[c]) channel_done_bytes[c] += bytes;
}

// (Per link, from one pass over the running transfers, kept while the clock and the set
// of activities stay: the metrics ask for every link at the end of a run.)
double SgPlatform::Impl::in_flight_bytes(std::int32_t link) const {
  const Time now = sg4::Engine::get_clock();
  if (in_flight_at != now || in_flight_next_id != next_id || in_flight_pending != pending.size()) {
    in_flight.assign(link_bytes.size(), 0.0);
    for (const auto& [id, p] : pending)
      if (p.channel != kNone && p.activity)
        for (std::int32_t l : channel_route[p.channel]) in_flight[static_cast<std::size_t>(l)] += moved_bytes(p, false);
    in_flight_at = now;
    in_flight_next_id = next_id;
    in_flight_pending = pending.size();
  }
  return in_flight[static_cast<std::size_t>(link)];
}

void SgPlatform::Impl::on_time_advance(double) {
  // Everything in the graveyard completed in an earlier round and was fully post()ed.
  graveyard.clear();
}

double SgPlatform::Impl::moved_bytes(const Pending& p, bool finished) {
  return static_cast<double>(p.bytes) - (finished ? 0.0 : p.activity->get_remaining());
}

void SgPlatform::Impl::launch_comm(SgActivityId id, Bytes bytes) {
  Pending& p = pending.at(id);
  // SimGrid bounds a flow's rate by its route's bandwidths when it starts and never lifts
  // that bound: a flow that starts on a contended channel (set_channel_bandwidth) starts at
  // the channel's full bandwidth, so that it speeds up again when the contention ends; the
  // link's own bandwidth then holds it to the contended rate meanwhile.
  sg4::Link* own = channel_links[static_cast<std::size_t>(p.channel)];
  const double full = graph.channels[static_cast<std::size_t>(p.channel)].bandwidth;
  const double now_bw = own ? own->get_bandwidth() : full;
  if (now_bw != full) own->set_bandwidth(full);
  sg4::CommPtr comm = sg4::Comm::sendto_async(channel_src[p.channel], channel_dst[p.channel], bytes);
  if (now_bw != full) own->set_bandwidth(now_bw);
  by_activity[comm.get()] = id;
  p.activity = comm;
  p.bytes = bytes;
}

void SgPlatform::Impl::complete(SgActivityId id, Time finish_s, bool ok) {
  auto it = pending.find(id);
  if (it == pending.end()) return;
  Pending p = std::move(it->second);
  pending.erase(it);
  if (p.timed_exec) {
    mark_device(p.device, -1);
    if (device_exec[p.device] == id) device_exec[p.device] = 0;
  }
  if (p.activity) {
    if (p.channel != kNone) add_route_bytes(p.channel, moved_bytes(p, ok));
    graveyard.push_back(std::move(p.activity));  // SimGrid still uses it after this signal
    if (p.device != kNone) mark_device(p.device, -1);
  }
  if (stopped || !p.done) return;
  // Callbacks are not called from here: activities that end at the same instant reach
  // SimGrid's signal in an order of its own (its heaps, its zones), and the workload and
  // the scheduler react to the order they hear of them. They are collected and called in
  // start order (SgActivityId) from a timer at this instant, which runs once SimGrid has
  // handled everything ending now (or when run() / run_until() returns).
  due.push_back({SgCompletion{p.id, p.start_s, finish_s, ok}, std::move(p.done)});
  if (!flush_timer) {
    Impl* self = this;
    flush_timer = simgrid::kernel::timer::Timer::set(sg4::Engine::get_clock(), [self] {
      self->flush_timer = nullptr;
      self->flush_due();
    });
  }
}

void SgPlatform::Impl::flush_now() {
  if (flush_timer) {
    flush_timer->remove();
    flush_timer = nullptr;
  }
  flush_due();
}

void SgPlatform::Impl::flush_due() {
  std::vector<Due> now_due;
  now_due.swap(due);
  std::sort(now_due.begin(), now_due.end(), [](const Due& a, const Due& b) { return a.c.id < b.c.id; });
  for (Due& d : now_due) {
    if (stopped) return;
    try {
      d.done(d.c);
    } catch (...) {
      // Unwinding through SimGrid's loop would strand half-processed activities, and
      // cancelling them from inside a signal crashes SimGrid 3.32 when other activities
      // end at the same instant: their cancelled actions wait for the engine's next round,
      // by which time the activities are freed (EngineImpl::handle_ended_actions; found by
      // fuzzing the replay log, test ExceptionFromACallbackAmongSimultaneousCompletions).
      // Stop starting anything now, cancel the rest from a timer at this instant, and
      // rethrow from run().
      if (!error) {
        error = std::current_exception();
        stopped = true;
        Impl* self = this;
        simgrid::kernel::timer::Timer::set(sg4::Engine::get_clock(), [self] { self->stop_all(); });
      }
      return;
    }
  }
}

void SgPlatform::Impl::set_timer(SgActivityId id, Time date, bool launch, Bytes bytes) {
  Impl* self = this;
  timers[id] = simgrid::kernel::timer::Timer::set(date, [self, id, launch, bytes] {
    self->timers.erase(id);
    if (self->stopped || !self->pending.count(id)) return;  // (cancelled: nothing to do)
    if (launch)
      self->launch_comm(id, bytes);
    else
      self->complete(id, sg4::Engine::get_clock(), true);
  });
}

void SgPlatform::Impl::stop_all() {
  stopped = true;
  for (auto& [id, timer] : timers) {
    timer->remove();
    pending.erase(id);
  }
  timers.clear();
  std::vector<sg4::ActivityPtr> running;
  for (auto& [id, p] : pending)
    if (p.activity) running.push_back(p.activity);
  for (const sg4::ActivityPtr& a : running) a->cancel();  // fires on_completion (CANCELED)
  pending.clear();
  graveyard.insert(graveyard.end(), running.begin(), running.end());
}

// ---------------------------------------------------------------------------------------
// Public API.

namespace {
// Registers a new pending activity started now (shared by transfers and execs).
SgPlatform::Impl::Pending& register_pending(SgPlatform::Impl& m, Time now_s, SgCallback done, const char* who) {
  if (m.stopped) throw std::logic_error(std::string("SgPlatform::") + who + ": the simulation was stopped by a failing callback");
  const SgActivityId id = m.next_id++;
  SgPlatform::Impl::Pending& p = m.pending[id];
  p.id = id;
  p.start_s = now_s;
  p.done = std::move(done);
  return p;
}
}  // namespace

SgActivityId SgPlatform::start_transfer(ChannelId c, Bytes bytes, SgCallback done) {
  Impl& m = *impl_;
  if (c < 0 || c >= static_cast<ChannelId>(m.graph.channels.size()))
    throw std::out_of_range("SgPlatform::start_transfer: unknown channel " + std::to_string(c));
  const Time now_s = now();
  Impl::Pending& p = register_pending(m, now_s, std::move(done), "start_transfer");
  p.channel = c;
  const SgActivityId id = p.id;

  const Time latency = m.graph.channels[c].latency;
  if (bytes == 0) {
    m.set_timer(id, now_s + latency, false, 0);  // SimGrid never starts a 0-byte Comm: latency alone
  } else if (latency > 0) {
    m.set_timer(id, now_s + latency, true, bytes);  // latency phase outside SimGrid (see header)
  } else {
    m.launch_comm(id, bytes);
  }
  return id;
}

SgActivityId SgPlatform::start_exec(DeviceId d, Time seconds, SgCallback done) {
  Impl& m = *impl_;
  if (d < 0 || d >= static_cast<DeviceId>(m.graph.computes.size()))
    throw std::out_of_range("SgPlatform::start_exec: unknown device " + std::to_string(d));
  if (!(seconds >= 0) || !std::isfinite(seconds))
    throw std::invalid_argument("SgPlatform::start_exec: duration must be finite and >= 0");
  const Time now_s = now();
  Impl::Pending& p = register_pending(m, now_s, std::move(done), "start_exec");
  p.device = d;
  const SgActivityId id = p.id;

  if (seconds == 0) {
    m.set_timer(id, now_s, false, 0);
    return id;
  }
  if (m.exclusive_execs) {
    if (m.device_active[d] > 0)
      throw std::logic_error("SgPlatform::start_exec: device " + m.graph.computes[d].name + " already runs an exec (exclusive_execs)");
    p.timed_exec = true;
    p.work_left = seconds;
    p.since = now_s;
    m.device_exec[d] = id;
    m.mark_device(d, +1);
    m.set_timer(id, now_s + seconds * m.device_slowdown[d], false, 0);
    return id;
  }
  // Convention: hosts run at 1 flop/s, so flops = seconds of device time. (Here, with
  // SimGrid's own Execs for its Paje trace, set_device_slowdown is not applied.)
  sg4::ExecPtr exec = sg4::Exec::init();
  exec->set_flops_amount(seconds);
  exec->set_host(m.compute_hosts[d]);
  m.by_activity[exec.get()] = id;
  p.activity = exec;
  m.mark_device(d, +1);
  exec->start();
  return id;
}

SgActivityId SgPlatform::start_timer(Time delay, SgCallback done) {
  Impl& m = *impl_;
  if (!(delay >= 0) || !std::isfinite(delay)) throw std::invalid_argument("SgPlatform::start_timer: delay must be finite and >= 0");
  const Time now_s = now();
  Impl::Pending& p = register_pending(m, now_s, std::move(done), "start_timer");
  const SgActivityId id = p.id;
  m.set_timer(id, now_s + delay, false, 0);
  return id;
}

void SgPlatform::cancel(SgActivityId id) {
  Impl& m = *impl_;
  auto it = m.pending.find(id);
  if (it == m.pending.end()) return;
  Impl::Pending p = std::move(it->second);
  m.pending.erase(it);  // complete() ignores it from now on; a latency timer finds nothing to do
  if (p.timed_exec) {  // its end must not keep the engine's clock running
    m.mark_device(p.device, -1);
    if (m.device_exec[p.device] == id) m.device_exec[p.device] = 0;
    if (auto t = m.timers.find(id); t != m.timers.end()) {
      t->second->remove();
      m.timers.erase(t);
    }
    return;
  }
  if (!p.activity) return;
  if (p.channel != kNone) m.add_route_bytes(p.channel, Impl::moved_bytes(p, false));
  if (p.device != kNone) m.mark_device(p.device, -1);
  sg4::ActivityPtr a = p.activity;
  m.graveyard.push_back(a);
  simgrid::kernel::timer::Timer::set(now(), [a] {
    if (a->get_state() == sg4::Activity::State::STARTED) a->cancel();
  });
}

void SgPlatform::run() {
  impl_->engine->run();
  while (!impl_->due.empty() && !impl_->stopped) {  // completions at the very end
    impl_->flush_now();
    impl_->engine->run();
  }
  impl_->graveyard.clear();
  rethrow_callback_error();
}

void SgPlatform::rethrow_callback_error() {
  if (impl_->error) std::rethrow_exception(std::exchange(impl_->error, nullptr));
}

void SgPlatform::run_until(Time t) {
  // SimGrid 3.32's run_until stops as soon as the clock is within 1e-5 s of t, possibly
  // before events in that window; loop until the clock really reaches t.
  if (std::isinf(t) && t > 0) return run();
  while (now() < t) {
    const Time before = now();
    impl_->engine->run_until(t);
    if (!impl_->due.empty() && !impl_->stopped) impl_->flush_now();  // completions where it stopped
    impl_->graveyard.clear();
    rethrow_callback_error();
    if (!(now() > before)) break;
  }
}

Time SgPlatform::now() const { return sg4::Engine::get_clock(); }

std::size_t SgPlatform::in_flight() const { return impl_->pending.size(); }

double SgPlatform::resource_bytes(ResourceId r) const {
  const std::int32_t l = impl_->resource_link_index(r);
  return impl_->link_bytes.at(static_cast<std::size_t>(l)) + impl_->in_flight_bytes(l);
}

double SgPlatform::channel_bytes(ChannelId c) const {
  if (c < 0 || c >= static_cast<ChannelId>(impl_->graph.channels.size()))
    throw std::out_of_range("SgPlatform::channel_bytes: unknown channel " + std::to_string(c));
  const Impl& m = *impl_;
  if (m.channel_links[c]) return m.link_bytes[m.channel_link_index(c)] + m.in_flight_bytes(m.channel_link_index(c));
  double bytes = m.channel_done_bytes[c];  // a channel without its own link: its transfers' bytes
  for (const auto& [id, p] : m.pending)
    if (p.channel == c && p.activity) bytes += Impl::moved_bytes(p, false);
  return bytes;
}

double SgPlatform::device_busy_s(DeviceId d) const {
  const Impl& m = *impl_;
  return m.device_work_s.at(d) + (m.device_active[d] > 0 ? now() - m.device_since[d] : 0.0);
}

const DeviceGraph& SgPlatform::graph() const { return impl_->graph; }

void SgPlatform::set_device_slowdown(DeviceId d, double factor) {
  Impl& m = *impl_;
  const auto di = static_cast<std::size_t>(d);
  if (m.device_slowdown.at(di) == factor) return;
  const SgActivityId id = m.exclusive_execs ? m.device_exec[di] : 0;
  if (auto it = id ? m.pending.find(id) : m.pending.end(); it != m.pending.end()) {
    // The running exec: what it did at the old speed, the rest at the new one.
    Impl::Pending& p = it->second;
    const Time now_s = now();
    p.work_left = std::max(0.0, p.work_left - (now_s - p.since) / m.device_slowdown[di]);
    p.since = now_s;
    if (auto t = m.timers.find(id); t != m.timers.end()) {
      t->second->remove();
      m.timers.erase(t);
    }
    m.set_timer(id, now_s + p.work_left * factor, false, 0);
  }
  m.device_slowdown[di] = factor;
}

void SgPlatform::set_channel_bandwidth(ChannelId c, double bandwidth) {
  sg4::Link* l = impl_->channel_links.at(static_cast<std::size_t>(c));
  if (!l) throw std::logic_error("SgPlatform::set_channel_bandwidth: channel " + std::to_string(c) + " has no link of its own");
  if (l->get_bandwidth() != bandwidth) l->set_bandwidth(bandwidth);
}

std::string SgPlatform::resource_link_name(ResourceId r) const { return impl_->resource_links.at(r)->get_name(); }

std::string SgPlatform::channel_link_name(ChannelId c) const {
  const sg4::Link* l = impl_->channel_links.at(c);
  return l ? l->get_name() : std::string();
}

std::vector<std::string> SgPlatform::route_links(ChannelId c) const {
  std::vector<sg4::Link*> links;
  double latency = 0;
  impl_->channel_src.at(c)->route_to(impl_->channel_dst.at(c), links, &latency);
  std::vector<std::string> names;
  for (const sg4::Link* l : links) names.push_back(l->get_name());
  return names;
}

}  // namespace rayline::sim
