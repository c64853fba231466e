// Sim-internal view of SgPlatform: the SimGrid objects behind each DCG element. Include
// only from sim/*.cpp (it pulls in SimGrid's forward declarations).
#pragma once
#include <simgrid/forward.h>

#include <cstdint>
#include <exception>
#include <memory>
#include <unordered_map>
#include <vector>

#include "sim/sg_platform.hpp"

namespace rayline::sim {

struct SgPlatform::Impl {
  // The engine first: members below hold SimGrid references and are destroyed before it.
  std::unique_ptr<simgrid::s4u::Engine> engine;
  DeviceGraph graph;

  std::vector<simgrid::s4u::Host*> memory_hosts;   // by MemId
  std::vector<simgrid::s4u::Host*> compute_hosts;  // by DeviceId
  std::vector<simgrid::s4u::Link*> resource_links;  // by ResourceId
  std::vector<simgrid::s4u::Link*> channel_links;   // by ChannelId; null when its resources imply it
  std::vector<simgrid::s4u::Host*> channel_src;     // by ChannelId: memory host, or a relay
  std::vector<simgrid::s4u::Host*> channel_dst;     // by ChannelId: memory host, or a network relay
  std::vector<std::vector<std::int32_t>> channel_route;  // by ChannelId: link indices of its route

  // Exact integrals, by link index (resources first, then channels) and by DeviceId.
  std::vector<double> link_bytes;
  std::vector<double> channel_done_bytes;  // by ChannelId, channels without a link: finished transfers' bytes
  std::vector<double> device_work_s;  // closed busy intervals
  std::vector<int> device_active;      // execs running on it
  std::vector<double> device_since;    // while device_active > 0: when the busy interval began
  bool exclusive_execs = false;        // SgOptions::exclusive_execs
  std::vector<double> device_slowdown;  // set_device_slowdown (1: full speed)
  std::vector<SgActivityId> device_exec;  // exclusive_execs: the timed exec running on it (0: none)

  struct Pending {
    SgActivityId id = 0;
    Time start_s = 0;
    ChannelId channel = kNone;  // transfer, or
    DeviceId device = kNone;    // exec
    bool timed_exec = false;    // an exec run as a timer (SgOptions::exclusive_execs)
    Time work_left = 0, since = 0;  // a timed exec: device seconds still to run at `since`
    Bytes bytes = 0;            // a transfer's payload, once its Comm started
    SgCallback done;
    simgrid::s4u::ActivityPtr activity;  // null during the latency phase
  };
  // Bytes a transfer's Comm has moved: all of them once it finished, else what it has sent.
  static double moved_bytes(const Pending& p, bool finished);
  std::unordered_map<SgActivityId, Pending> pending;
  std::unordered_map<const simgrid::s4u::Activity*, SgActivityId> by_activity;
  std::unordered_map<SgActivityId, simgrid::kernel::timer::Timer*> timers;  // latency phases, 0-cost items
  // Finished activities: SimGrid still touches them after on_completion returns, so the
  // last reference is dropped at the next time step (or after run()).
  std::vector<simgrid::s4u::ActivityPtr> graveyard;
  SgActivityId next_id = 1;
  // Completions not yet reported (see complete()), called in SgActivityId order.
  struct Due {
    SgCompletion c;
    SgCallback done;
  };
  std::vector<Due> due;
  simgrid::kernel::timer::Timer* flush_timer = nullptr;  // calls flush_due() at this instant
  // Set once a callback threw (or on destruction): every pending activity is cancelled,
  // no callback fires any more, start_* refuses; run() rethrows `error`.
  bool stopped = false;
  std::exception_ptr error;

  void launch_comm(SgActivityId id, Bytes bytes);           // latency paid: start the Comm
  void set_timer(SgActivityId id, Time date, bool launch, Bytes bytes);
  void stop_all();                                          // cancel everything pending
  void complete(SgActivityId id, Time finish_s, bool ok);  // bookkeeping; the user callback is due
  void flush_due();                                         // call due callbacks in start order
  void flush_now();                                         // the same from maestro, timer withdrawn
  void on_time_advance(double delta);                      // empties the graveyard
  void add_route_bytes(ChannelId c, double bytes);          // a transfer ended or was cancelled
  double in_flight_bytes(std::int32_t link) const;          // bytes running transfers sent through it
  mutable std::vector<double> in_flight;                    // in_flight_bytes() of every link, taken
  mutable Time in_flight_at = -1;                           // at this clock,
  mutable SgActivityId in_flight_next_id = 0;               // with this next id
  mutable std::size_t in_flight_pending = 0;                // and this many pending
  void mark_device(DeviceId d, int delta_count);

  std::int32_t resource_link_index(ResourceId r) const { return r; }
  std::int32_t channel_link_index(ChannelId c) const {
    return static_cast<std::int32_t>(graph.resources.size()) + c;
  }
};

}  // namespace rayline::sim
