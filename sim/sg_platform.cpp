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

}  // namespace

// ---------------------------------------------------------------------------------------
// Construction: engine, hosts, links, routes, signals.

SgPlatform::SgPlatform(const DeviceGraph& graph, const SgOptions& options) : impl_(std::make_unique<Impl>()) {
  if (g_engine_created)
    throw std::logic_error("SgPlatform: SimGrid's engine is a process-wide singleton; one SgPlatform per process");
  Impl& m = *impl_;
  m.graph = graph;
  m.graph.finalize();
  const DeviceGraph& g = m.graph;
  check_unique_host_names(g);
  check_bandwidths(g);

  g_engine_created = true;
  m.engine = std::make_unique<sg4::Engine>("rayline");
  configure_engine(options);

  // Memory hosts, relays and every link live in one full zone (routes are explicit, one
  // per channel). Compute hosts never communicate and sit in an empty sibling zone, which
  // keeps the full zone's N x N route table to the memory hosts. The root has no routes
  // (a zone with children needs gateways for every route it holds).
  sg4::NetZone* root = sg4::create_empty_zone("rayline");
  sg4::NetZone* net = sg4::create_full_zone("rayline.net");
  net->set_parent(root);
  sg4::NetZone* cpu = sg4::create_empty_zone("rayline.compute");
  cpu->set_parent(root);

  for (const MemoryDevice& md : g.memories) m.memory_hosts.push_back(net->create_host(md.name, 1.0));
  for (const ComputeDevice& cd : g.computes) m.compute_hosts.push_back(cpu->create_host(cd.name, 1.0));

  for (std::size_t r = 0; r < g.resources.size(); ++r)
    m.resource_links.push_back(make_link(net, "res[" + std::to_string(r) + "]:" + g.resources[r].name,
                                         g.resources[r].bandwidth));

  std::map<std::pair<MemId, MemId>, int> pair_uses;
  for (std::size_t i = 0; i < g.channels.size(); ++i) {
    const Channel& c = g.channels[i];
    sg4::Link* own = make_link(net, "chan[" + std::to_string(i) + "]:" + c.name, c.bandwidth);
    m.channel_links.push_back(own);

    std::vector<sg4::LinkInRoute> route{sg4::LinkInRoute(own)};
    std::vector<ResourceId> res;  // in the channel's order; a resource listed twice is used once
    for (ResourceId r : c.resources)
      if (std::find(res.begin(), res.end(), r) == res.end()) res.push_back(r);
    std::vector<std::int32_t>& used = m.channel_route.emplace_back();
    used.push_back(m.channel_link_index(static_cast<ChannelId>(i)));
    for (ResourceId r : res) {
      route.emplace_back(m.resource_links[r]);
      used.push_back(m.resource_link_index(r));
    }

    sg4::Host* src = m.memory_hosts[c.from];
    if (pair_uses[{c.from, c.to}]++ > 0)  // a second channel between the same pair
      src = net->create_host(g.memories[c.from].name + "~relay" + std::to_string(i), 1.0);
    sg4::Host* dst = m.memory_hosts[c.to];
    net->add_route(src->get_netpoint(), dst->get_netpoint(), nullptr, nullptr, route, /*symmetrical=*/false);
    m.channel_src.push_back(src);
    m.channel_dst.push_back(dst);
  }
  net->seal();
  cpu->seal();
  root->seal();

  const std::size_t nlinks = g.resources.size() + g.channels.size();
  m.link_bytes.assign(nlinks, 0.0);
  m.link_active.assign(nlinks, 0);
  m.link_listed.assign(nlinks, 0);
  m.device_work_s.assign(g.computes.size(), 0.0);
  m.device_active.assign(g.computes.size(), 0);
  m.device_listed.assign(g.computes.size(), 0);

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

void SgPlatform::Impl::mark_active(std::int32_t link, int delta_count) {
  link_active[link] += delta_count;
  if (link_active[link] > 0 && !link_listed[link]) {
    link_listed[link] = 1;
    active_links.push_back(link);
  }
}

void SgPlatform::Impl::mark_device(DeviceId d, int delta_count) {
  device_active[d] += delta_count;
  if (device_active[d] > 0 && !device_listed[d]) {
    device_listed[d] = 1;
    active_devices.push_back(d);
  }
}

void SgPlatform::Impl::use_channel_links(ChannelId c, int delta_count) {
  for (std::int32_t l : channel_route[c]) mark_active(l, delta_count);
}

void SgPlatform::Impl::on_time_advance(double delta) {
  // Link::get_usage() still holds the rate of the interval that just ended.
  const std::size_t nres = resource_links.size();
  for (std::size_t i = 0; i < active_links.size();) {
    const std::int32_t l = active_links[i];
    if (link_active[l] == 0) {
      link_listed[l] = 0;
      active_links[i] = active_links.back();
      active_links.pop_back();
      continue;
    }
    const sg4::Link* link = static_cast<std::size_t>(l) < nres ? resource_links[l] : channel_links[l - nres];
    link_bytes[l] += link->get_usage() * delta;
    ++i;
  }
  for (std::size_t i = 0; i < active_devices.size();) {
    const DeviceId d = active_devices[i];
    if (device_active[d] == 0) {
      device_listed[d] = 0;
      active_devices[i] = active_devices.back();
      active_devices.pop_back();
      continue;
    }
    device_work_s[d] += compute_hosts[d]->get_load() * delta;  // speed 1: flops/s = busy fraction
    ++i;
  }
  // Everything in the graveyard completed in an earlier round and was fully post()ed.
  graveyard.clear();
}

void SgPlatform::Impl::launch_comm(SgActivityId id, Bytes bytes) {
  Pending& p = pending.at(id);
  sg4::CommPtr comm = sg4::Comm::sendto_async(channel_src[p.channel], channel_dst[p.channel], bytes);
  by_activity[comm.get()] = id;
  p.activity = comm;
  use_channel_links(p.channel, +1);
}

void SgPlatform::Impl::complete(SgActivityId id, Time finish_s, bool ok) {
  auto it = pending.find(id);
  if (it == pending.end()) return;
  Pending p = std::move(it->second);
  pending.erase(it);
  if (p.activity) {
    graveyard.push_back(std::move(p.activity));  // SimGrid still uses it after this signal
    if (p.channel != kNone) use_channel_links(p.channel, -1);
    if (p.device != kNone) mark_device(p.device, -1);
  }
  if (stopped || !p.done) return;
  try {
    p.done(SgCompletion{p.id, p.start_s, finish_s, ok});
  } catch (...) {
    // Unwinding through SimGrid's loop would strand half-processed activities, and
    // cancelling them from inside this signal crashes SimGrid 3.32 when other activities
    // end at the same instant: their cancelled actions wait for the engine's next round,
    // by which time the activities are freed (EngineImpl::handle_ended_actions; found by
    // fuzzing the replay log, test ExceptionFromACallbackAmongSimultaneousCompletions).
    // Stop starting anything now, cancel the rest from a timer at this instant (outside
    // the signal), and rethrow from run().
    if (!error) {
      error = std::current_exception();
      stopped = true;
      Impl* self = this;
      simgrid::kernel::timer::Timer::set(sg4::Engine::get_clock(), [self] { self->stop_all(); });
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
  // Convention: hosts run at 1 flop/s, so flops = seconds of device time.
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
  if (!p.activity) return;
  if (p.channel != kNone) m.use_channel_links(p.channel, -1);
  if (p.device != kNone) m.mark_device(p.device, -1);
  sg4::ActivityPtr a = p.activity;
  m.graveyard.push_back(a);
  simgrid::kernel::timer::Timer::set(now(), [a] {
    if (a->get_state() == sg4::Activity::State::STARTED) a->cancel();
  });
}

void SgPlatform::run() {
  impl_->engine->run();
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
    impl_->graveyard.clear();
    rethrow_callback_error();
    if (!(now() > before)) break;
  }
}

Time SgPlatform::now() const { return sg4::Engine::get_clock(); }

std::size_t SgPlatform::in_flight() const { return impl_->pending.size(); }

double SgPlatform::resource_bytes(ResourceId r) const { return impl_->link_bytes.at(impl_->resource_link_index(r)); }

double SgPlatform::channel_bytes(ChannelId c) const {
  if (c < 0 || c >= static_cast<ChannelId>(impl_->graph.channels.size()))
    throw std::out_of_range("SgPlatform::channel_bytes: unknown channel " + std::to_string(c));
  return impl_->link_bytes[impl_->channel_link_index(c)];
}

double SgPlatform::device_busy_s(DeviceId d) const { return impl_->device_work_s.at(d); }

const DeviceGraph& SgPlatform::graph() const { return impl_->graph; }

std::string SgPlatform::resource_link_name(ResourceId r) const { return impl_->resource_links.at(r)->get_name(); }

std::string SgPlatform::channel_link_name(ChannelId c) const { return impl_->channel_links.at(c)->get_name(); }

std::vector<std::string> SgPlatform::route_links(ChannelId c) const {
  std::vector<sg4::Link*> links;
  double latency = 0;
  impl_->channel_src.at(c)->route_to(impl_->channel_dst.at(c), links, &latency);
  std::vector<std::string> names;
  for (const sg4::Link* l : links) names.push_back(l->get_name());
  return names;
}

}  // namespace rayline::sim
