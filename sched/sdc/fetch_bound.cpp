#include "sched/sdc/fetch_bound.hpp"

#include <algorithm>
#include <limits>

namespace rayline {

FetchBound::FetchBound(const DeviceGraph& g) : n_(g.memories.size()) {
  lat_.assign(n_ * n_, kNever);
  inv_bw_.assign(n_ * n_, kNever);
  for (std::size_t i = 0; i < n_; ++i) lat_[i * n_ + i] = inv_bw_[i * n_ + i] = 0;
  for (const Channel& c : g.channels) {
    const std::size_t k = static_cast<std::size_t>(c.from) * n_ + static_cast<std::size_t>(c.to);
    lat_[k] = std::min(lat_[k], c.latency);
    inv_bw_[k] = std::min(inv_bw_[k], 1.0 / c.bandwidth);
  }
  all_pairs_minima(g);
  relay_in_.resize(n_);
  own_in_.resize(n_);
  direct_to_.assign(n_ * n_, kNone);
  for (std::size_t c = 0; c < g.channels.size(); ++c) {
    const Channel& ch = g.channels[c];
    ChannelId& d = direct_to_[static_cast<std::size_t>(ch.to) * n_ + static_cast<std::size_t>(ch.from)];
    d = d == kNone ? static_cast<ChannelId>(c) : kSeveral;
    bool relay = false;
    for (ChannelId in : g.in_channels(ch.from)) relay = relay || g.channels[in].from != ch.to;
    (relay ? relay_in_ : own_in_)[static_cast<std::size_t>(ch.to)].push_back(
        {static_cast<ChannelId>(c), ch.from, g.memories[static_cast<std::size_t>(ch.from)].capacity, ch.latency, ch.bandwidth});
  }
  lat_to_.resize(n_ * n_);
  inv_bw_to_.resize(n_ * n_);
  for (std::size_t i = 0; i < n_; ++i)
    for (std::size_t j = 0; j < n_; ++j) {
      lat_to_[j * n_ + i] = lat_[i * n_ + j];
      inv_bw_to_[j * n_ + i] = inv_bw_[i * n_ + j];
    }
  network_groups(g);
  build_relay_runs(g);
}

void FetchBound::build_relay_runs(const DeviceGraph& g) {
  relay_runs_.assign(n_, {});
  std::vector<ChannelId> channels;
  for (std::size_t m = 0; m < n_; ++m) {
    const std::vector<Relay>& rs = relay_in_[m];
    auto key = [&](const Relay& r) {
      const std::int32_t k = g.channels[static_cast<std::size_t>(r.channel)].network;
      return k >= 0 ? group_of(k, r.from) : -1;
    };
    for (std::uint32_t i = 0; i < rs.size();) {
      const std::int32_t group = key(rs[i]);
      std::uint32_t e = i + 1;
      while (group >= 0 && e < rs.size() && key(rs[e]) == group) ++e;
      channels.clear();
      for (std::uint32_t j = i; j < e; ++j) channels.push_back(rs[j].channel);
      relay_runs_[m].push_back({i, e, Span::of(g, channels)});
      i = e;
    }
  }
}

FetchBound::Common FetchBound::common_resources(const DeviceGraph& g, const std::vector<ChannelId>& channels) {
  Common out;
  if (channels.empty()) return out;
  int k = 0;
  for (ResourceId r : g.channels[static_cast<std::size_t>(channels.front())].resources) {
    bool everywhere = true;
    for (ChannelId c : channels) {
      const auto& rs = g.channels[static_cast<std::size_t>(c)].resources;
      everywhere = everywhere && std::find(rs.begin(), rs.end(), r) != rs.end();
    }
    if (everywhere && k < kCommon) out.r[k++] = r;
  }
  return out;
}

FetchBound::Span FetchBound::Span::of(const DeviceGraph& g, const std::vector<ChannelId>& channels) {
  Span span;
  span.common = common_resources(g, channels);
  for (ChannelId c : channels) {
    span.min_latency = std::min(span.min_latency, g.channels[static_cast<std::size_t>(c)].latency);
    span.max_bandwidth = std::max(span.max_bandwidth, g.channels[static_cast<std::size_t>(c)].bandwidth);
  }
  return span;
}

void FetchBound::network_groups(const DeviceGraph& g) {
  const std::size_t nets = g.networks.size();
  group_of_.assign(nets * n_, -1);
  std::vector<std::int32_t> group_network;
  for (std::size_t k = 0; k < nets; ++k) {
    const Network& net = g.networks[k];
    const auto base = static_cast<std::int32_t>(group_network.size());
    const std::size_t count = std::max<std::size_t>(1, net.racks.size());
    for (std::size_t r = 0; r < count; ++r) group_network.push_back(static_cast<std::int32_t>(k));
    for (const NetworkMember& q : net.members)
      group_of_[k * n_ + static_cast<std::size_t>(q.memory)] = base + (q.rack >= 0 ? q.rack : 0);
  }
  groups_ = group_network.size();
  network_rest_.assign(n_ * groups_, NetworkRest{});
  // Cuts: per group, its nodes, and the channels leaving and entering them.
  nodes_ = g.nodes.size();
  node_of_.resize(n_);
  for (std::size_t m = 0; m < n_; ++m) node_of_[m] = g.memories[m].node;
  node_group_.assign(nets * nodes_, -1);
  groups_info_.assign(groups_, Group{});
  std::vector<std::vector<char>> in_group(groups_, std::vector<char>(nodes_, 0));
  for (std::size_t k = 0; k < nets; ++k)
    for (const NetworkMember& q : g.networks[k].members) {
      const std::int32_t gi = group_of(static_cast<std::int32_t>(k), q.memory);
      node_group_[k * nodes_ + static_cast<std::size_t>(q.node)] = gi;
      in_group[static_cast<std::size_t>(gi)][static_cast<std::size_t>(q.node)] = 1;
    }
  overlap_.assign(groups_ * groups_, 0);
  for (std::size_t a = 0; a < groups_; ++a)
    for (std::size_t b = 0; b < groups_; ++b)
      for (std::size_t v = 0; v < nodes_ && !overlap_[a * groups_ + b]; ++v)
        overlap_[a * groups_ + b] = in_group[a][v] && in_group[b][v];
  {
    std::vector<ChannelId> leave, enter;
    for (std::size_t gi = 0; gi < groups_; ++gi) {
      Group& gr = groups_info_[gi];
      gr.network = group_network[gi];
      leave.clear();
      enter.clear();
      for (std::size_t c = 0; c < g.channels.size(); ++c) {
        const Channel& ch = g.channels[c];
        const bool from_in = in_group[gi][static_cast<std::size_t>(node_of_[static_cast<std::size_t>(ch.from)])];
        const bool to_in = in_group[gi][static_cast<std::size_t>(node_of_[static_cast<std::size_t>(ch.to)])];
        if (from_in && !to_in) leave.push_back(static_cast<ChannelId>(c));
        if (!from_in && to_in) enter.push_back(static_cast<ChannelId>(c));
      }
      gr.leave = common_resources(g, leave);
      gr.enter = common_resources(g, enter);
      if (!enter.empty()) gr.enter_bandwidth = 0;
      for (ChannelId c : enter) {
        gr.enter_latency = std::min(gr.enter_latency, g.channels[static_cast<std::size_t>(c)].latency);
        gr.enter_bandwidth = std::max(gr.enter_bandwidth, g.channels[static_cast<std::size_t>(c)].bandwidth);
      }
    }
  }
  std::vector<std::vector<MemId>> members(groups_);
  for (std::size_t k = 0; k < nets; ++k)
    for (const NetworkMember& q : g.networks[k].members)
      members[static_cast<std::size_t>(group_of(static_cast<std::int32_t>(k), q.memory))].push_back(q.memory);
  std::vector<std::vector<ChannelId>> in(groups_);  // per group: its members' channels into m
  for (std::size_t m = 0; m < n_; ++m) {
    for (std::size_t gi = 0; gi < groups_; ++gi) {
      NetworkRest& r = network_rest_[m * groups_ + gi];
      for (MemId q : members[gi]) {
        if (static_cast<std::size_t>(q) == m) continue;
        const std::size_t at = m * n_ + static_cast<std::size_t>(q);
        r.latency = std::min(r.latency, lat_to_[at]);
        r.inv_bw = std::min(r.inv_bw, inv_bw_to_[at]);
      }
      in[gi].clear();
    }
    for (ChannelId c : g.in_channels(static_cast<MemId>(m))) {
      const MemId q = g.channels[static_cast<std::size_t>(c)].from;
      for (std::size_t k = 0; k < nets; ++k)
        if (const std::int32_t gi = group_of(static_cast<std::int32_t>(k), q); gi >= 0) in[static_cast<std::size_t>(gi)].push_back(c);
    }
    for (std::size_t gi = 0; gi < groups_; ++gi) {
      NetworkRest& r = network_rest_[m * groups_ + gi];
      if (in[gi].empty()) continue;  // no channel into m from the group: relays only
      r.in = common_resources(g, in[gi]);
      r.in_bandwidth = 0;
      for (ChannelId c : in[gi]) {
        r.in_latency = std::min(r.in_latency, g.channels[static_cast<std::size_t>(c)].latency);
        r.in_bandwidth = std::max(r.in_bandwidth, g.channels[static_cast<std::size_t>(c)].bandwidth);
      }
    }
  }
}

// L and W (see the header) by Floyd-Warshall, with leaves peeled first: a memory device
// whose channels all lead to and come from one other device u (a disk or a GPU memory
// hanging off its node's RAM) is no intermediate of any shortest path (entering and
// leaving it is a cycle through u), so the search runs over the devices left, and a
// peeled device's row and column follow from u's: d(v, x) = d(v, u) + d(u, x),
// d(x, v) = d(x, u) + d(u, v). Peeling repeats (a device may become a leaf once its own
// leaves are gone). On a cluster this leaves one device per node: O(nodes^3), not
// O(devices^3).
void FetchBound::all_pairs_minima(const DeviceGraph& g) {
  const std::size_t n = n_;
  std::vector<std::pair<std::size_t, std::size_t>> edges;  // both directions, then made distinct
  edges.reserve(2 * g.channels.size());
  for (const Channel& c : g.channels) {
    edges.emplace_back(static_cast<std::size_t>(c.from), static_cast<std::size_t>(c.to));
    edges.emplace_back(static_cast<std::size_t>(c.to), static_cast<std::size_t>(c.from));
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::vector<std::vector<std::size_t>> nbr(n);  // distinct neighbours, either direction
  for (const auto& [a, b] : edges) nbr[a].push_back(b);
  std::vector<char> gone(n, 0);
  std::vector<std::size_t> degree(n), peeled, via(n, n);
  for (std::size_t v = 0; v < n; ++v) degree[v] = nbr[v].size();
  std::vector<std::size_t> leaves;
  for (std::size_t v = 0; v < n; ++v)
    if (degree[v] == 1) leaves.push_back(v);
  while (!leaves.empty()) {
    const std::size_t v = leaves.back();
    leaves.pop_back();
    if (gone[v] || degree[v] != 1) continue;
    std::size_t u = n;
    for (std::size_t x : nbr[v])
      if (!gone[x]) u = x;
    if (degree[u] == 1) continue;  // the last two of a component: keep both in the search
    gone[v] = 1;
    via[v] = u;
    peeled.push_back(v);
    if (--degree[u] == 1) leaves.push_back(u);
  }
  std::vector<std::size_t> core;
  for (std::size_t v = 0; v < n; ++v)
    if (!gone[v]) core.push_back(v);

  for (std::vector<double>* d : {&lat_, &inv_bw_}) {
    std::vector<double>& D = *d;
    // Floyd-Warshall over the core (rows that cannot reach k are skipped: min(x, inf) = x;
    // D[i][k] does not change while row i is relaxed through k, as D[k][k] = 0), on a
    // compact copy of the core's rows and columns so that the inner loop runs over
    // contiguous memory (it vectorises; at 1 024 nodes the core is the 1 024 RAMs). Every
    // entry sees the same updates in the same order as on D itself.
    const std::size_t nc = core.size();
    std::vector<double> C(nc * nc);
    for (std::size_t a = 0; a < nc; ++a)
      for (std::size_t b = 0; b < nc; ++b) C[a * nc + b] = D[core[a] * n + core[b]];
    for (std::size_t k = 0; k < nc; ++k) {
      const double* ck = C.data() + k * nc;
      for (std::size_t i = 0; i < nc; ++i) {
        double* ci = C.data() + i * nc;
        const double cik = ci[k];
        if (cik == kNever || i == k) continue;
        for (std::size_t j = 0; j < nc; ++j) ci[j] = std::min(ci[j], cik + ck[j]);
      }
    }
    for (std::size_t a = 0; a < nc; ++a)
      for (std::size_t b = 0; b < nc; ++b) D[core[a] * n + core[b]] = C[a * nc + b];
    // Peeled devices in reverse order: each against every device present when it was peeled.
    std::vector<std::size_t> present = core;
    for (auto it = peeled.rbegin(); it != peeled.rend(); ++it) {
      const std::size_t v = *it, u = via[v];
      const double vu = D[v * n + u], uv = D[u * n + v];
      for (std::size_t x : present) {
        if (x == u) continue;
        D[v * n + x] = vu + D[u * n + x];
        D[x * n + v] = D[x * n + u] + uv;
      }
      present.push_back(v);
    }
  }
}

void FetchBound::add_slot(BlockId b) const {
  const auto bi = static_cast<std::size_t>(b);
  if (bi >= slot_of_block_.size()) slot_of_block_.resize(std::max(2 * slot_of_block_.size(), bi + 1), -1);
  if (slot_of_block_[bi] < 0) {
    slot_of_block_[bi] = static_cast<std::int32_t>(memos_.size() / n_);
    memos_.resize(memos_.size() + n_);
    slotted_.push_back(b);
  }
}


std::uint64_t FetchBound::channel_stamp(const Schedule& s, ChannelId c) const {
  std::uint64_t v = 0;
  for (ResourceId r : s.graph().channels[static_cast<std::size_t>(c)].resources) v += s.resource_version(r);
  return v;
}

// Within a planning pass every term of the minimum only grows (channels get busier, the
// holders term is fixed while the holders are): while the attaining channel is unchanged,
// so is the minimum.
Time FetchBound::lower_bound(const Schedule& s, BlockId b, MemId m, Time now) const {
  Memo& e = memo(b, m).lower;
  const std::uint64_t hv = s.holders_version(b);
  if (e.epoch == epoch_ && e.holders == hv && (e.arg == kNone || e.in == channel_stamp(s, e.arg))) return e.value;
  ChannelId arg = kNone;
  e.value = lower_bound_uncached(s, b, m, now, true, &arg);
  e.holders = hv;
  e.arg = arg;
  e.in = arg == kNone ? 0 : channel_stamp(s, arg);
  e.epoch = epoch_;
  return e.value;
}

Time FetchBound::lower_bound_once(const Schedule& s, BlockId b, MemId m, Time now) const {
  return lower_bound_uncached(s, b, m, now, false);
}

Time FetchBound::lower_bound_uncached(const Schedule& s, BlockId b, MemId m, Time now, bool memoised_holders,
                                      ChannelId* arg) const {
  if (const Copy* c = s.copy_at(b, m)) return std::max(now, s.copy_ready(*c));
  const DeviceGraph& g = s.graph();
  const Bytes bytes = s.pool().block(b).bytes;
  Time best = kNever;
  for (ChannelId c : g.in_channels(m)) {
    // A hop whose start bound + T_LAT already does not beat the minimum is skipped before
    // the holders term and Eq. 1's division: |w|/T_BW >= 0 and rounding is monotone, so
    // its sum would not beat it either (the minimum and its channel are bit-identical).
    const Channel& ch = g.channels[static_cast<std::size_t>(c)];
    const Time finish = s.channel_finish(c);
    if (!(finish + ch.latency < best)) continue;
    const Time at_src = memoised_holders ? holders_bound(s, b, ch.from, now) : holders_bound_uncached(s, b, ch.from, now);
    if (at_src == kNever) continue;
    const Time start = std::max(at_src, finish);
    if (!(start + ch.latency < best)) continue;
    const Time t = start + g.transfer_time(c, bytes);
    if (t < best) {
      best = t;
      if (arg) *arg = c;
    }
  }
  return best;
}

Time FetchBound::direct_upper_bound(const Schedule& s, BlockId b, MemId m, Time now) const {
  if (const Copy* c = s.copy_at(b, m)) return std::max(now, s.copy_ready(*c));
  const DeviceGraph& g = s.graph();
  const Bytes bytes = s.pool().block(b).bytes;
  Time best = kNever;
  for (const Copy& h : s.copies(b))
    for (ChannelId c : g.out_channels(h.mem)) {
      const MemId p = g.channels[c].to;
      if (s.copy_at(b, p)) continue;  // a holder takes no second copy (as in SDC)
      const Time t1 = std::max({now, s.copy_ready(h), s.channel_finish(c)}) + g.transfer_time(c, bytes);
      if (p == m) {
        best = std::min(best, t1);
        continue;
      }
      if (t1 >= best || g.memories[p].capacity < bytes) continue;
      // The second hop p -> m (direct_to_: the channel, or several to scan).
      auto hop2 = [&](ChannelId c2) { best = std::min(best, std::max(t1, s.channel_finish(c2)) + g.transfer_time(c2, bytes)); };
      if (const ChannelId c2 = direct_to_[static_cast<std::size_t>(m) * n_ + static_cast<std::size_t>(p)]; c2 >= 0) {
        hop2(c2);
      } else if (c2 == kSeveral) {
        for (ChannelId c3 : g.out_channels(p))
          if (g.channels[c3].to == m) hop2(c3);
      }
    }
  return best;
}

Time FetchBound::last_hop_floor(const Schedule& s, BlockId b, MemId m) const {
  const double w = static_cast<double>(s.pool().block(b).bytes);
  Time best = kNever;
  auto term = [&](const Relay& r) {
    if (const Time t = r.lands_before(s.channel_finish(r.channel), w, best); t < best) best = t;
  };
  best = relay_min(s, m, w, best, -kNever, [](const Relay&) { return true; });
  // A holder's own channel into m that is no relay channel (from m's GPU memory or disk).
  for (const Relay& r : own_in_[static_cast<std::size_t>(m)])
    if (s.copy_at(b, r.from)) term(r);
  return best;
}

Time FetchBound::holders_bound_fill(const Schedule& s, BlockId b, MemId m, Time now, Memo& e, std::uint64_t hv) const {
  e.value = holders_bound_uncached(s, b, m, now);
  e.holders = hv;
  e.epoch = epoch_;
  return e.value;
}

// The leading initial copies of a block with many (Schedule::initial_prefix, all ready at
// the same time) enter as one floor, max(now, ready) + their least uncontended fetch to m,
// lowered by a relative 1e-14 so that rounding never lifts it above any of their terms; the floor's
// least fetch is kept per (block, m) while the prefix's stamp holds. The other copies
// count exactly as below.
Time FetchBound::holders_bound_uncached(const Schedule& s, BlockId b, MemId m, Time now) const {
  const double bytes = static_cast<double>(s.pool().block(b).bytes);
  Time best = kNever;
  const std::vector<Copy>& copies = s.copies(b);
  std::size_t first = 0;
  if (copies.size() > Schedule::kScannedCopies) {
    if (const Copy* c = s.copy_at(b, m)) return std::max(now, s.copy_ready(*c));
    if (const Schedule::CopyPrefix pre = s.initial_prefix(b); pre.count > 0) {
      PrefixFloor& pf = prefix_floors_[b];
      if (pf.stamp != pre.stamp || pf.bytes != bytes || pf.least.size() != n_) {
        pf.stamp = pre.stamp;
        pf.bytes = bytes;
        pf.least.assign(n_, std::numeric_limits<double>::quiet_NaN());
        pf.ready = kNever;
        for (std::size_t k = 0; k < pre.count; ++k) pf.ready = std::min(pf.ready, s.copy_ready(copies[k]));
      }
      double& least = pf.least[static_cast<std::size_t>(m)];
      if (least != least) {
        least = kNever;
        for (std::size_t k = 0; k < pre.count; ++k) {
          const std::size_t i = static_cast<std::size_t>(copies[k].mem) * n_ + static_cast<std::size_t>(m);
          least = std::min(least, lat_[i] + bytes * inv_bw_[i]);
        }
      }
      if (least < kNever) best = (std::max(now, pf.ready) + least) * (1 - 1e-14);
      first = pre.count;
    }
  }
  for (std::size_t k = first; k < copies.size(); ++k) {
    const Copy& c = copies[k];
    const Time ready = std::max(now, s.copy_ready(c));
    if (c.mem == m) return ready;
    const std::size_t i = static_cast<std::size_t>(c.mem) * n_ + static_cast<std::size_t>(m);
    best = std::min(best, ready + lat_[i] + bytes * inv_bw_[i]);
  }
  return best;
}

}  // namespace rayline
