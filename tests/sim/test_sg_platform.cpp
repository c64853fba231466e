// SgPlatform: the DCG on SimGrid reproduces Eq. 1 exactly when alone, and shares
// resources the way the DCG says (half duplex, full duplex, NICs) under contention.
// Each TEST runs in its own process (gtest_discover_tests): one engine per process.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iterator>
#include <stdexcept>
#include <vector>

#include "common/error.hpp"
#include "sim/sg_platform.hpp"
#include "sim_fixture.hpp"

namespace rayline {
namespace {

using sim::SgCompletion;
using sim::SgPlatform;
using testing::Cluster;
using testing::rel_err;

constexpr double kTol = 1e-9;  // relative

struct Done {
  Time start = -1, finish = -1;
  bool ok = false;
  int calls = 0;
};
sim::SgCallback record(Done& d) {
  return [&d](const SgCompletion& c) {
    d.start = c.start_s;
    d.finish = c.finish_s;
    d.ok = c.ok;
    ++d.calls;
  };
}

// One transfer alone on each listed channel, one after the other; each must take Eq. 1.
double check_alone(const Cluster& cl, const std::vector<ChannelId>& channels, Bytes bytes) {
  SgPlatform p(cl.graph());
  std::vector<Done> done(channels.size());
  std::size_t next = 0;
  std::function<void()> start_next = [&] {
    if (next == channels.size()) return;
    const std::size_t i = next++;
    p.start_transfer(channels[i], bytes, [&, i](const SgCompletion& c) {
      record(done[i])(c);
      start_next();
    });
  };
  start_next();
  p.run();
  double worst = 0;
  for (std::size_t i = 0; i < channels.size(); ++i) {
    const Time want = cl.graph().transfer_time(channels[i], bytes);
    EXPECT_EQ(done[i].calls, 1);
    EXPECT_TRUE(done[i].ok);
    const double e = rel_err(done[i].finish - done[i].start, want);
    EXPECT_LE(e, kTol) << cl.graph().channels[channels[i]].name << ": " << done[i].finish - done[i].start
                       << " s, Eq. 1 says " << want;
    worst = std::max(worst, e);
  }
  std::printf("worst relative error over %zu channels: %.3g\n", channels.size(), worst);
  return worst;
}

TEST(SgPlatform, SataHalfDuplexMatchesEq1) {
  Cluster cl;
  check_alone(cl, {cl.disk_to_ram, cl.ram_to_disk}, Bytes(64) << 20);
}

TEST(SgPlatform, PcieFullDuplexMatchesEq1) {
  Cluster cl;
  check_alone(cl, {cl.a_h2d, cl.a_d2h, cl.b_h2d, cl.b_d2h}, Bytes(1) << 30);
}

TEST(SgPlatform, LanThroughNicsOfDifferentSpeedsMatchesEq1) {
  Cluster cl;
  // A (1G) <-> B, C (10G): limited by A's NIC; B -> C: limited by the channel itself.
  std::vector<ChannelId> lan;
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y)
      if (x != y) lan.push_back(cl.lan[x][y]);
  check_alone(cl, lan, 100'000'000);
}

TEST(SgPlatform, EveryChannelMatchesEq1ForManySizes) {
  Cluster cl;
  std::vector<ChannelId> all;
  for (int k = 0; k < 4; ++k)
    for (ChannelId c = 0; c < static_cast<ChannelId>(cl.graph().channels.size()); ++c) all.push_back(c);
  // one process, one engine: sizes cycle with the channel list
  SgPlatform p(cl.graph());
  const Bytes sizes[4] = {1, 4096, Bytes(1) << 20, 777'777'777};
  const std::size_t nch = cl.graph().channels.size();
  std::vector<Done> done(all.size());
  std::size_t next = 0;
  std::function<void()> start_next = [&] {
    if (next == all.size()) return;
    const std::size_t i = next++;
    p.start_transfer(all[i], sizes[i / nch], [&, i](const SgCompletion& c) {
      record(done[i])(c);
      start_next();
    });
  };
  start_next();
  p.run();
  double worst = 0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    const Time want = cl.graph().transfer_time(all[i], sizes[i / nch]);
    const double e = rel_err(done[i].finish - done[i].start, want);
    EXPECT_LE(e, kTol) << cl.graph().channels[all[i]].name << " bytes=" << sizes[i / nch];
    worst = std::max(worst, e);
  }
  std::printf("worst relative error over %zu transfers (1 B .. 778 MB): %.3g\n", all.size(), worst);
}

TEST(SgPlatform, HalfDuplexOppositeDirectionsShareTheResource) {
  Cluster cl;
  SgPlatform p(cl.graph());
  const Bytes bytes = 30'000'000;
  Done rd, wr;
  p.start_transfer(cl.disk_to_ram, bytes, record(rd));
  p.start_transfer(cl.ram_to_disk, bytes, record(wr));
  p.run();
  // same latency, then both at half bandwidth until both end together
  const Time want = Cluster::kSataLat + 2.0 * bytes / Cluster::kSataBw;
  EXPECT_LE(rel_err(rd.finish, want), kTol) << rd.finish;
  EXPECT_LE(rel_err(wr.finish, want), kTol) << wr.finish;
}

TEST(SgPlatform, FullDuplexOppositeDirectionsDoNotSlowEachOther) {
  Cluster cl;
  SgPlatform p(cl.graph());
  const Bytes bytes = Bytes(3) << 30;
  Done h2d, d2h;
  p.start_transfer(cl.a_h2d, bytes, record(h2d));
  p.start_transfer(cl.a_d2h, bytes, record(d2h));
  p.run();
  const Time want = cl.graph().transfer_time(cl.a_h2d, bytes);
  EXPECT_LE(rel_err(h2d.finish, want), kTol);
  EXPECT_LE(rel_err(d2h.finish, want), kTol);
}

TEST(SgPlatform, TwoTransfersOnOneChannelShareItsBandwidth) {
  Cluster cl;  // B -> C is limited by its channel link (1e9), not by its 10G NICs
  SgPlatform p(cl.graph());
  const Bytes bytes = 500'000'000;
  Done x, y;
  p.start_transfer(cl.lan[1][2], bytes, record(x));
  p.start_transfer(cl.lan[1][2], bytes, record(y));
  p.run();
  const Time want = Cluster::lan_latency(1, 2) + 2.0 * bytes / Cluster::kBcBw;
  EXPECT_LE(rel_err(x.finish, want), kTol) << x.finish;
  EXPECT_LE(rel_err(y.finish, want), kTol) << y.finish;
}

TEST(SgPlatform, TwoPeersShareTheSendersNic) {
  // A sends to B and to C at once: both go out through A's 1G NIC-out.
  Cluster cl;
  SgPlatform p(cl.graph());
  const Bytes bytes = 50'000'000;
  Done ab, ac;
  p.start_transfer(cl.lan[0][1], bytes, record(ab));
  p.start_transfer(cl.lan[0][2], bytes, record(ac));
  p.run();
  // Latencies differ (l_ab < l_ac): A->B runs alone at full rate during [l_ab, l_ac], then
  // the two split A's NIC equally (latency does not weight the share), then A->C alone.
  const double bw = Cluster::kNic1G;
  const Time l1 = Cluster::lan_latency(0, 1), l2 = Cluster::lan_latency(0, 2);
  ASSERT_LT(l1, l2);
  const double left1 = bytes - bw * (l2 - l1);  // A->B bytes still to send at l2
  const Time t1 = l2 + left1 / (bw / 2);
  const Time t2 = t1 + (bytes - left1) / bw;
  EXPECT_LE(rel_err(ab.finish, t1), kTol) << ab.finish << " vs " << t1;
  EXPECT_LE(rel_err(ac.finish, t2), kTol) << ac.finish << " vs " << t2;
  // Sanity: both slower than alone.
  EXPECT_GT(ab.finish, cl.graph().transfer_time(cl.lan[0][1], bytes) * 1.5);
}

TEST(SgPlatform, TwoPeersWithEqualLatencyEachGetHalfTheNic) {
  Cluster cl;
  cl.b.g.channels[cl.lan[0][2]].latency = cl.b.g.channels[cl.lan[0][1]].latency;
  SgPlatform p(cl.graph());
  const Bytes bytes = 50'000'000;
  Done ab, ac;
  p.start_transfer(cl.lan[0][1], bytes, record(ab));
  p.start_transfer(cl.lan[0][2], bytes, record(ac));
  p.run();
  const Time want = Cluster::lan_latency(0, 1) + 2.0 * bytes / Cluster::kNic1G;
  EXPECT_LE(rel_err(ab.finish, want), kTol);
  EXPECT_LE(rel_err(ac.finish, want), kTol);
}

TEST(SgPlatform, ReceiverNicIsSharedByTwoSenders) {
  Cluster cl;  // B -> A and C -> A both end in A's 1G NIC-in
  cl.b.g.channels[cl.lan[2][0]].latency = cl.b.g.channels[cl.lan[1][0]].latency;
  SgPlatform p(cl.graph());
  const Bytes bytes = 50'000'000;
  Done ba, ca;
  p.start_transfer(cl.lan[1][0], bytes, record(ba));
  p.start_transfer(cl.lan[2][0], bytes, record(ca));
  p.run();
  const Time want = Cluster::lan_latency(1, 0) + 2.0 * bytes / Cluster::kNic1G;
  EXPECT_LE(rel_err(ba.finish, want), kTol);
  EXPECT_LE(rel_err(ca.finish, want), kTol);
}

TEST(SgPlatform, ThreeHopChainCostsTheSumOfItsHops) {
  Cluster cl;  // A.disk -> A.ram -> (LAN) -> B.ram -> B.gpu0.mem
  SgPlatform p(cl.graph());
  const Bytes bytes = 40'000'000;
  const std::vector<ChannelId> path = {cl.disk_to_ram, cl.lan[0][1], cl.b_h2d};
  std::vector<Done> hop(path.size());
  std::function<void(std::size_t)> go = [&](std::size_t i) {
    p.start_transfer(path[i], bytes, [&, i](const SgCompletion& c) {
      record(hop[i])(c);
      if (i + 1 < path.size()) go(i + 1);
    });
  };
  go(0);
  p.run();
  Time want = 0;
  for (std::size_t i = 0; i < path.size(); ++i) {
    want += cl.graph().transfer_time(path[i], bytes);
    EXPECT_LE(rel_err(hop[i].finish, want), kTol) << "hop " << i;
  }
  EXPECT_LE(rel_err(p.now(), want), kTol);
}

TEST(SgPlatform, ExecOfTSecondsTakesT) {
  Cluster cl;
  SgPlatform p(cl.graph());
  Done e1, e2, e3;
  p.start_exec(cl.a_gpu, 0.75, [&](const SgCompletion& c) {
    record(e1)(c);
    p.start_exec(cl.a_gpu, 1e-3, record(e2));  // chained from the callback
  });
  p.start_exec(cl.a_cpu, 2.5, record(e3));      // another device: independent
  p.run();
  EXPECT_LE(rel_err(e1.finish, 0.75), kTol);
  EXPECT_LE(rel_err(e2.start, 0.75), kTol);
  EXPECT_LE(rel_err(e2.finish, 0.751), kTol);
  EXPECT_LE(rel_err(e3.finish, 2.5), kTol);
  EXPECT_LE(rel_err(p.device_busy_s(cl.a_gpu), 0.751), kTol);
  EXPECT_LE(rel_err(p.device_busy_s(cl.a_cpu), 2.5), kTol);
  EXPECT_EQ(p.device_busy_s(cl.b_gpu), 0.0);
}

TEST(SgPlatform, TwoExecsOnOneDeviceShareIt) {
  Cluster cl;
  SgPlatform p(cl.graph());
  Done a, b;
  p.start_exec(cl.b_gpu, 1.0, record(a));
  p.start_exec(cl.b_gpu, 3.0, record(b));
  p.run();
  EXPECT_LE(rel_err(a.finish, 2.0), kTol);  // both at half speed
  EXPECT_LE(rel_err(b.finish, 4.0), kTol);  // then alone
  EXPECT_LE(rel_err(p.device_busy_s(cl.b_gpu), 4.0), kTol);
}

// SgOptions::exclusive_execs: an exec alone on its device is a timer; the same timing, the
// same busy time (cancelled ones count up to the cancel), no clock left running after a
// cancel, and a second exec on a busy device is refused.
TEST(SgPlatform, ExclusiveExecsRunAsTimersWithTheSameTimes) {
  Cluster cl;
  rayline::sim::SgOptions opt;
  opt.exclusive_execs = true;
  SgPlatform p(cl.graph(), opt);
  Done e1, e2, e3;
  p.start_exec(cl.a_gpu, 0.75, [&](const SgCompletion& c) {
    record(e1)(c);
    p.start_exec(cl.a_gpu, 1e-3, record(e2));  // chained from the callback: the device is free
  });
  p.start_exec(cl.a_cpu, 2.5, record(e3));
  EXPECT_THROW(p.start_exec(cl.a_cpu, 1.0, [](const SgCompletion&) {}), std::logic_error);
  const rayline::sim::SgActivityId long_one = p.start_exec(cl.b_gpu, 100.0, [](const SgCompletion&) { ADD_FAILURE() << "cancelled"; });
  p.run_until(1.5);
  EXPECT_LE(rel_err(p.device_busy_s(cl.b_gpu), 1.5), kTol);  // running: counted up to now
  p.cancel(long_one);
  p.run();
  EXPECT_EQ(e1.finish, 0.75);
  EXPECT_EQ(e2.start, 0.75);
  EXPECT_EQ(e2.finish, 0.75 + 1e-3);
  EXPECT_EQ(e3.finish, 2.5);
  EXPECT_LE(rel_err(p.now(), 2.5), kTol) << "a cancelled exec must not keep the clock running";
  EXPECT_LE(rel_err(p.device_busy_s(cl.a_gpu), 0.751), kTol);
  EXPECT_LE(rel_err(p.device_busy_s(cl.a_cpu), 2.5), kTol);
  EXPECT_LE(rel_err(p.device_busy_s(cl.b_gpu), 1.5), kTol);
}

TEST(SgPlatform, IntegratedBytesPerResourceEqualBytesSent) {
  Cluster cl;
  SgPlatform p(cl.graph());
  const DeviceGraph& g = cl.graph();
  std::vector<double> sent_res(g.resources.size(), 0), sent_ch(g.channels.size(), 0);
  int completed = 0;
  auto send = [&](ChannelId c, Bytes bytes) {
    for (ResourceId r : g.channels[c].resources) sent_res[r] += static_cast<double>(bytes);
    sent_ch[c] += static_cast<double>(bytes);
    p.start_transfer(c, bytes, [&](const SgCompletion&) { ++completed; });
  };
  // A contended mix, with starts spread over time through exec callbacks.
  send(cl.disk_to_ram, 70'000'000);
  send(cl.ram_to_disk, 20'000'000);
  send(cl.lan[0][1], 33'000'000);
  send(cl.lan[0][2], 12'345'678);
  send(cl.lan[1][2], 900'000'000);
  send(cl.a_h2d, Bytes(5) << 30);
  p.start_exec(cl.a_cpu, 0.123, [&](const SgCompletion&) {
    send(cl.lan[2][0], 44'000'000);
    send(cl.lan[1][0], 1'000'000);
    send(cl.a_d2h, 123'456'789);
    send(cl.disk_to_ram, 5'000'000);
  });
  p.run();
  EXPECT_EQ(completed, 10);
  EXPECT_EQ(p.in_flight(), 0u);
  double worst = 0;
  for (ResourceId r = 0; r < static_cast<ResourceId>(g.resources.size()); ++r) {
    if (sent_res[r] == 0) {
      EXPECT_EQ(p.resource_bytes(r), 0.0) << g.resources[r].name;
      continue;
    }
    const double e = rel_err(p.resource_bytes(r), sent_res[r]);
    EXPECT_LE(e, kTol) << g.resources[r].name << ": " << p.resource_bytes(r) << " vs " << sent_res[r];
    worst = std::max(worst, e);
  }
  for (ChannelId c = 0; c < static_cast<ChannelId>(g.channels.size()); ++c) {
    if (sent_ch[c] == 0) continue;
    const double e = rel_err(p.channel_bytes(c), sent_ch[c]);
    EXPECT_LE(e, kTol) << g.channels[c].name;
    worst = std::max(worst, e);
  }
  std::printf("worst relative error of integrated bytes: %.3g\n", worst);
}

// A channel gets a link of its own only when it is slower than its slowest resource (here
// B -> C); for the others that link's constraint would be implied by the resources'.
TEST(SgPlatform, EveryChannelIsRoutedThroughExactlyItsLinks) {
  Cluster cl;
  SgPlatform p(cl.graph());
  int own = 0;
  for (ChannelId c = 0; c < static_cast<ChannelId>(cl.graph().channels.size()); ++c) {
    std::vector<std::string> want;
    if (!p.channel_link_name(c).empty()) {
      want.push_back(p.channel_link_name(c));
      ++own;
    }
    for (ResourceId r : cl.graph().channels[c].resources) want.push_back(p.resource_link_name(r));
    EXPECT_EQ(p.route_links(c), want) << cl.graph().channels[c].name;
  }
  EXPECT_EQ(own, 1);
  EXPECT_FALSE(p.channel_link_name(cl.lan[1][2]).empty());
}

TEST(SgPlatform, TwoChannelsBetweenTheSamePairKeepTheirOwnRoutes) {
  Cluster cl;  // a second A -> B LAN, over its own (slower) resources
  const ResourceId out2 = cl.b.resource("A.nic2.out", 50e6), in2 = cl.b.resource("B.nic2.in", 50e6);
  const ChannelId second = cl.b.channel("lan2:A->B", "lan", cl.a_ram, cl.b_ram, 2e-3, 50e6, {out2, in2});
  cl.b.g.finalize();
  SgPlatform p(cl.graph());
  EXPECT_EQ(p.route_links(second), (std::vector<std::string>{p.resource_link_name(out2), p.resource_link_name(in2)}));
  EXPECT_EQ(p.route_links(cl.lan[0][1]).size(), 2u);
  EXPECT_NE(p.route_links(cl.lan[0][1]), p.route_links(second));
  const Bytes bytes = 10'000'000;
  Done one, two;
  p.start_transfer(cl.lan[0][1], bytes, record(one));
  p.start_transfer(second, bytes, record(two));
  p.run();
  EXPECT_LE(rel_err(one.finish, cl.graph().transfer_time(cl.lan[0][1], bytes)), kTol);  // no shared resource
  EXPECT_LE(rel_err(two.finish, cl.graph().transfer_time(second, bytes)), kTol);
}

TEST(SgPlatform, ZeroBytesCostTheLatencyAndZeroSecondsCostNothing) {
  Cluster cl;
  SgPlatform p(cl.graph());
  Done t, e, first;
  p.start_exec(cl.b_gpu, 0.0, record(first));  // before run(): fires at 0, from inside run()
  EXPECT_EQ(first.calls, 0);
  p.start_exec(cl.a_cpu, 0.5, [&](const SgCompletion&) {
    p.start_transfer(cl.disk_to_ram, 0, record(t));
    p.start_exec(cl.a_gpu, 0.0, record(e));
  });
  p.run();
  EXPECT_EQ(t.calls, 1);
  EXPECT_LE(rel_err(t.finish, 0.5 + Cluster::kSataLat), kTol);
  EXPECT_EQ(e.calls, 1);
  EXPECT_LE(rel_err(e.finish, 0.5), kTol);
  EXPECT_EQ(first.calls, 1);
  EXPECT_EQ(first.finish, 0.0);
  EXPECT_EQ(p.in_flight(), 0u);
}

TEST(SgPlatform, RunUntilProcessesEventsUpToTAndStopsAtT) {
  Cluster cl;
  SgPlatform p(cl.graph());
  Done near, later;
  p.start_exec(cl.a_cpu, 1.0 - 4e-6, record(near));  // inside SimGrid's 1e-5 stop window
  p.start_exec(cl.a_gpu, 1.5, record(later));
  p.run_until(1.0);
  EXPECT_EQ(p.now(), 1.0);
  EXPECT_EQ(near.calls, 1);
  EXPECT_EQ(later.calls, 0);
  EXPECT_EQ(p.in_flight(), 1u);
  p.run_until(2.0);
  EXPECT_EQ(later.calls, 1);
  EXPECT_LE(rel_err(later.finish, 1.5), kTol);
  EXPECT_EQ(p.now(), 2.0);
  // Starting from main between runs works too.
  Done t;
  p.start_transfer(cl.a_h2d, 1'000'000, record(t));
  p.run();
  EXPECT_EQ(t.start, 2.0);
  EXPECT_LE(rel_err(t.finish, 2.0 + cl.graph().transfer_time(cl.a_h2d, 1'000'000)), kTol);
}

TEST(SgPlatform, PajeTraceThroughExtraConfig) {
  Cluster cl;
  const std::string file = ::testing::TempDir() + "rayline_sg_platform.trace";
  sim::SgOptions opt;
  opt.config = {"tracing:yes", "tracing/uncategorized:yes", "tracing/filename:" + file, "tracing/precision:9"};
  {
    SgPlatform p(cl.graph(), opt);
    Done t;
    p.start_transfer(cl.lan[0][1], 1'000'000, record(t));
    p.run();
    EXPECT_EQ(t.calls, 1);
  }
  std::ifstream in(file);
  ASSERT_TRUE(in.good()) << file;
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("A.nic.out"), std::string::npos);
  EXPECT_NE(text.find("bandwidth_used"), std::string::npos);
  std::remove(file.c_str());
}

TEST(SgPlatform, ChannelFasterThanItsResourceIsRejected) {
  Cluster cl;
  cl.b.g.channels[cl.lan[0][1]].bandwidth = Cluster::kNic10G;  // A's NIC is 1G
  EXPECT_THROW(SgPlatform p(cl.graph()), InputError);
}

TEST(SgPlatform, SecondPlatformInOneProcessIsRefused) {
  Cluster cl;
  SgPlatform p(cl.graph());
  EXPECT_THROW(SgPlatform q(cl.graph()), std::logic_error);
}

}  // namespace
}  // namespace rayline

namespace rayline {
namespace {

TEST(SgPlatform, DestroyedWithActivitiesInFlight) {
  Cluster cl;
  auto p = std::make_unique<SgPlatform>(cl.graph());
  Done t, l, e;
  p->start_transfer(cl.lan[0][1], 1'000'000'000, record(t));  // in its SimGrid phase
  p->start_transfer(cl.disk_to_ram, 1'000, record(l));        // still in its latency phase
  p->start_exec(cl.a_gpu, 10.0, record(e));
  p->run_until(1e-3);
  EXPECT_EQ(p->in_flight(), 3u);
  p.reset();  // must not crash; callbacks never fire
  EXPECT_EQ(t.calls + l.calls + e.calls, 0);
}

TEST(SgPlatform, ExceptionFromACallbackStopsTheRunCleanly) {
  Cluster cl;
  SgPlatform p(cl.graph());
  Done t, l, e;
  p.start_exec(cl.a_cpu, 1.0, [](const SgCompletion&) { throw std::runtime_error("boom"); });
  p.start_transfer(cl.lan[0][1], 1'000'000'000, record(t));  // running at t = 1
  p.start_exec(cl.a_gpu, 0.999, [&](const SgCompletion&) {
    p.start_transfer(cl.disk_to_ram, 1'000, record(l));       // in its latency phase at t = 1
  });
  p.start_exec(cl.b_gpu, 5.0, record(e));
  EXPECT_THROW(p.run(), std::runtime_error);
  EXPECT_EQ(t.calls + l.calls + e.calls, 0);
  EXPECT_EQ(p.in_flight(), 0u);
  EXPECT_LT(p.now(), 1.5);
  EXPECT_THROW(p.start_exec(cl.a_cpu, 1.0, nullptr), std::logic_error);
}

// The same, with other activities ending at the very instant the callback throws (what a
// bad replay log did mid-simulation): cancelling them from inside SimGrid's completion
// signal crashed SimGrid 3.32 (use after free in EngineImpl::handle_ended_actions), so the
// rest is cancelled from a timer at that instant. Identical transfers sharing one channel
// end together and the first callback throws; with a horizon ahead the engine then runs
// another round, where the old adapter's cancelled activities had already been freed.
TEST(SgPlatform, ExceptionFromACallbackAmongSimultaneousCompletions) {
  Cluster cl;
  SgPlatform p(cl.graph());
  Done later;
  int calls = 0;
  Time thrown_at = -1;
  auto cb = [&](const SgCompletion& c) {
    if (calls++ == 0) {
      thrown_at = c.finish_s;
      throw std::runtime_error("boom");
    }
    p.start_exec(cl.a_cpu, 0.5, record(later));  // throws: the run was stopped
  };
  for (int k = 0; k < 4; ++k) {
    p.start_transfer(cl.disk_to_ram, 1'500'000, cb);
    p.start_exec(cl.a_gpu, 1.0, cb);
  }
  EXPECT_THROW(p.run_until(10.0), std::runtime_error);
  EXPECT_EQ(later.calls, 0);  // nothing started after the failure completes
  EXPECT_EQ(p.in_flight(), 0u);
  EXPECT_GT(thrown_at, 0.0);
  EXPECT_LT(thrown_at, 1.0);  // the transfers' common finish, long before the horizon
}

// Thousands of chained, overlapping activities: every one completes once, nothing leaks
// or is freed early (run under RAYLINE_SANITIZE), and the byte integrals still match.
TEST(SgPlatform, ManyChainedActivitiesUnderContention) {
  Cluster cl;
  SgPlatform p(cl.graph());
  const DeviceGraph& g = cl.graph();
  const int nch = static_cast<int>(g.channels.size());
  std::vector<double> sent_res(g.resources.size(), 0);
  std::uint64_t rng = 42;
  auto next = [&rng] {
    rng = rng * 6364136223846793005ULL + 1442695040888963407ULL;
    return rng >> 33;
  };
  int started = 0, completed = 0;
  std::function<void(int)> chain = [&](int lane) {
    if (started >= 20000) return;
    ++started;
    if (lane % 4 == 3) {
      const DeviceId d = static_cast<DeviceId>(next() % g.computes.size());
      p.start_exec(d, 1e-4 * static_cast<double>(next() % 100), [&, lane](const SgCompletion& c) {
        ++completed;
        EXPECT_TRUE(c.ok);
        chain(lane);
      });
      return;
    }
    const ChannelId c = static_cast<ChannelId>(next() % nch);
    const Bytes bytes = next() % 50'000'000;
    for (ResourceId r : g.channels[c].resources) sent_res[r] += static_cast<double>(bytes);
    p.start_transfer(c, bytes, [&, lane](const SgCompletion& done) {
      ++completed;
      EXPECT_TRUE(done.ok);
      chain(lane);
    });
  };
  for (int lane = 0; lane < 64; ++lane) chain(lane);
  p.run();
  EXPECT_EQ(completed, started);
  EXPECT_EQ(p.in_flight(), 0u);
  for (ResourceId r = 0; r < static_cast<ResourceId>(g.resources.size()); ++r) {
    if (sent_res[r] == 0) continue;
    EXPECT_LE(rel_err(p.resource_bytes(r), sent_res[r]), 1e-9) << g.resources[r].name;
  }
  std::printf("%d activities, simulated %.3f s\n", completed, p.now());
}

}  // namespace
}  // namespace rayline

namespace rayline {
namespace {
// Activities that end at the same instant are reported in the order they were started,
// whatever order SimGrid's models and heaps hold them in: the scheduler and the workload
// react to the order they hear of them, and that must not depend on how the platform is
// built. Execs and transfers (two network models' worth of heaps) ending together, started
// in an interleaved order.
TEST(SgPlatform, SimultaneousCompletionsAreReportedInStartOrder) {
  testing::SimDcg b;
  const NodeId n = b.node("N");
  const MemId m0 = b.mem(n, "m0", MemoryKind::Host), m1 = b.mem(n, "m1", MemoryKind::Host);
  std::vector<DeviceId> devs;
  for (int i = 0; i < 4; ++i) devs.push_back(b.dev(m0, "cpu" + std::to_string(i), ComputeKind::Cpu));
  std::vector<ChannelId> chans;
  for (int i = 0; i < 4; ++i) {
    const ResourceId r = b.resource("r" + std::to_string(i), 1e6);
    chans.push_back(b.channel("c" + std::to_string(i), "test", m0, m1, 0.0, 1e6, {r}));
  }
  b.g.finalize();
  SgPlatform p(b.g);
  std::vector<int> order;
  std::vector<sim::SgActivityId> ids;
  for (int i = 0; i < 4; ++i) {  // transfer, exec, transfer, exec, ...: all end at t = 1
    ids.push_back(p.start_transfer(chans[static_cast<std::size_t>(3 - i)], 1'000'000,
                                   [&order, i](const SgCompletion&) { order.push_back(2 * i); }));
    ids.push_back(p.start_exec(devs[static_cast<std::size_t>(3 - i)], 1.0,
                               [&order, i](const SgCompletion&) { order.push_back(2 * i + 1); }));
  }
  p.run();
  EXPECT_EQ(order, (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7}));
  EXPECT_TRUE(std::is_sorted(ids.begin(), ids.end()));
  EXPECT_EQ(p.now(), 1.0);
}
}  // namespace
}  // namespace rayline
