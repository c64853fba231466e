// SgPlatform: a DeviceGraph (DCG, Sec. 3.2) turned into a SimGrid 3.32 platform, plus the
// few engine calls the executor needs (start a transfer or an exec from maestro, run,
// exact per-link byte counters). This header is SimGrid-free; SimGrid types stay in
// sg_platform.cpp and the sim-internal header sg_platform_internal.hpp.
//
// Conventions (why: see sim/README.md, "Platform model"):
//  * Engine: network/model:CM02, network/crosstraffic:0, network/TCP-gamma:1e30, set
//    before the first zone, so a transfer alone on channel c takes exactly Eq. 1,
//    latency(c) + bytes / bandwidth(c).
//  * Hosts: one per memory device (named as the device) and one per compute device
//    (named as the device, speed 1 flop/s, 1 core): an exec of T seconds is T flops.
//  * Links, all SHARED and with zero latency: one per Resource (its bandwidth), and one
//    per Channel only when the channel is slower than its slowest resource (otherwise its
//    constraint is implied). The route of channel c is [channel link if any, resource
//    links...]. Networks are star zones (racks: stars inside), so a network of N members
//    costs O(N) links and routes, not N^2.
//  * Latency is paid by a kernel timer before the Comm starts, not by SimGrid links:
//    CM02 weights a flow's share by its route latency (RTT-unfair), so flows of channels
//    with different latencies on one resource would not share it equally. With zero-
//    latency links every flow has the same weight and max-min sharing is equal. During
//    the latency phase a flow consumes no bandwidth, exactly as in CM02.
//  * Activities ending at the same instant are reported in start order (SgActivityId),
//    whatever order SimGrid's heaps hold them in.
//  * Several channels between the same (from, to) pair: the first uses the route
//    from-host -> to-host, each further one sends from its own relay host
//    "<from>~relay<c>" (a SimGrid route is unique per host pair).
//
// The SimGrid engine is a process-wide singleton: one SgPlatform per process, ever
// (a second one throws std::logic_error). Tests run each case in its own process.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "sched/core/device_graph.hpp"
#include "sched/core/types.hpp"

namespace rayline::sim {

struct SgOptions {
  // Extra SimGrid settings "name:value" (e.g. "network/optim:Full", "tracing:yes"),
  // applied after the exact-timing recipe and before the platform is built.
  std::vector<std::string> config;
  // xbt log control string; the default hides SimGrid's "Configuration change" chatter.
  std::string log_control = "root.thresh:warning";
  // The caller runs at most one exec at a time per compute device (SimExecutor's
  // timelines): an exec alone on its 1 flop/s host takes exactly its seconds, so it runs
  // as a kernel timer. (SimGrid 3.32 registers and later unregisters a host-state handler
  // per Exec in a list of every live exec, which grows with the device count.) A second
  // exec on a busy device is then a logic_error.
  bool exclusive_execs = false;
};

using SgActivityId = std::uint64_t;

// What a completion callback receives.
struct SgCompletion {
  SgActivityId id = 0;
  Time start_s = 0;   // when start_transfer / start_exec was called (before any latency)
  Time finish_s = 0;  // true completion date
  bool ok = true;     // false when SimGrid reports a failure or cancel
};
using SgCallback = std::function<void(const SgCompletion&)>;

class SgPlatform {
 public:
  // Configures the engine and builds the platform. Throws InputError for a graph SimGrid
  // cannot represent exactly (non-positive resource bandwidth, a channel faster than one
  // of its resources, name clashes) and std::logic_error for a second SgPlatform.
  explicit SgPlatform(const DeviceGraph& graph, const SgOptions& options = {});
  ~SgPlatform();
  SgPlatform(const SgPlatform&) = delete;
  SgPlatform& operator=(const SgPlatform&) = delete;

  // Start moving `bytes` over channel c now; `done` fires at now + latency(c) + the
  // (possibly contended) transfer time. 0 bytes cost exactly latency(c).
  SgActivityId start_transfer(ChannelId c, Bytes bytes, SgCallback done);
  // Start an exec of `seconds` of device time on compute device d (shared equally with
  // any other exec running on d). 0 seconds completes at now.
  SgActivityId start_exec(DeviceId d, Time seconds, SgCallback done);

  // From now on, compute device d runs its execs `factor` times slower (1: full speed), the
  // one running included (its remaining work; with SgOptions::exclusive_execs only).
  void set_device_slowdown(DeviceId d, double factor);
  // From now on, the flows on channel c share `bandwidth` (those in flight too). Only for a
  // channel with Channel::cpu_contention > 0, which has a link of its own for this.
  void set_channel_bandwidth(ChannelId c, double bandwidth);
  // `done` fires at now + delay (a wake-up; nothing is used).
  SgActivityId start_timer(Time delay, SgCallback done);
  // Stops a pending activity now, as a device turned off would (SimGrid's Host::turn_off
  // fails an Exec the same way): its callback never fires, and what it used is freed now.
  // The SimGrid activity is cancelled from a timer at this instant, outside any signal
  // (SimGrid 3.32 crashes when an activity is cancelled from inside a completion signal
  // while others end at the same instant). Unknown or finished ids are ignored.
  void cancel(SgActivityId id);

  // Callbacks fire from inside run()/run_until(), never from start_*; they may start new
  // activities. If a callback throws, every pending activity is cancelled (no further
  // callbacks), run()/run_until() rethrow the exception, and start_* refuse afterwards.
  void run();              // until nothing is pending
  void run_until(Time t);  // process every event up to t; afterwards now() == t
  Time now() const;

  std::size_t in_flight() const;  // started and not yet completed (latency phase included)

  // Exact integrals (sum of rate x interval, updated at every engine time step).
  double resource_bytes(ResourceId r) const;  // bytes through resource r
  double channel_bytes(ChannelId c) const;    // bytes moved on channel c
  double device_busy_s(DeviceId d) const;     // seconds of exec work done on device d

  const DeviceGraph& graph() const;

  // Platform introspection (tests, debugging): SimGrid's names for the links of resource
  // r / channel c, and the links SimGrid actually routes a transfer on channel c through.
  std::string resource_link_name(ResourceId r) const;
  std::string channel_link_name(ChannelId c) const;
  std::vector<std::string> route_links(ChannelId c) const;

  // Sim-internal access (definition in sg_platform_internal.hpp).
  struct Impl;
  Impl& impl() { return *impl_; }
  const Impl& impl() const { return *impl_; }

 private:
  void rethrow_callback_error();
  std::unique_ptr<Impl> impl_;
};

}  // namespace rayline::sim
