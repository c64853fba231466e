#include "sched/policy/rayline/ownership.hpp"

#include <algorithm>
#include <numeric>

#include "sched/policy/image_split.hpp"

namespace rayline {

bool Ownership::replicated() const {
  return std::all_of(groups.begin(), groups.end(), [](const std::vector<NodeId>& n) { return n.size() == 1; });
}

namespace {
// Node i takes the blocks whose middle byte falls in its share of the scene [0, total):
// shares in proportion to `weight`, each capped at `cap` (water-filling: what a capped node
// cannot take goes to the others in proportion to theirs).
std::vector<NodeId> split_blocks(const std::vector<NodeId>& nodes, const std::vector<double>& weight,
                                 const std::vector<double>& cap, const std::vector<Bytes>& bytes) {
  const double total = static_cast<double>(std::accumulate(bytes.begin(), bytes.end(), Bytes{0}));
  const std::size_t n = nodes.size();
  std::vector<bool> capped(n, false);
  std::vector<double> share(n, 0.0);
  for (bool settled = false; !settled;) {
    double left = total, w = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (capped[i]) left -= cap[i];
      else w += weight[i];
    }
    settled = true;
    if (w <= 0 || left <= 0) break;
    for (std::size_t i = 0; i < n; ++i)
      if (!capped[i] && left * weight[i] / w > cap[i]) capped[i] = true, settled = false;
    if (settled)
      for (std::size_t i = 0; i < n; ++i)
        if (!capped[i]) share[i] = left * weight[i] / w;
  }
  double given = 0, wsum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (capped[i]) share[i] = cap[i];
    given += share[i];
    wsum += weight[i];
  }
  if (given < total && wsum > 0)  // every node capped: the rest in proportion to weight (over capacity)
    for (std::size_t i = 0; i < n; ++i) share[i] += (total - given) * weight[i] / wsum;
  std::vector<NodeId> owner(bytes.size(), nodes.empty() ? kNone : nodes.back());
  double at = 0, end = 0;
  std::size_t k = 0;
  if (n > 0) end = share[0];
  for (std::size_t b = 0; b < bytes.size(); ++b) {
    const double mid = at + 0.5 * static_cast<double>(bytes[b]);
    while (k + 1 < n && mid >= end) end += share[++k];
    owner[b] = nodes.empty() ? kNone : nodes[k];
    at += static_cast<double>(bytes[b]);
  }
  return owner;
}
}  // namespace

std::vector<double> node_lan_bandwidth(const DeviceGraph& g) {
  std::vector<double> net(g.nodes.size(), 0.0), p2p(g.nodes.size(), 0.0);
  for (const Network& nw : g.networks)
    for (const NetworkMember& m : nw.members)
      if (m.node >= 0 && m.out != kNone && m.in != kNone)
        net[static_cast<std::size_t>(m.node)] +=
            std::min(g.resources[static_cast<std::size_t>(m.out)].bandwidth, g.resources[static_cast<std::size_t>(m.in)].bandwidth);
  for (const Channel& c : g.channels) {
    if (c.network != kNone) continue;
    const NodeId a = g.memories[static_cast<std::size_t>(c.from)].node, b = g.memories[static_cast<std::size_t>(c.to)].node;
    if (a == b || a < 0 || b < 0) continue;
    p2p[static_cast<std::size_t>(a)] = std::max(p2p[static_cast<std::size_t>(a)], c.bandwidth);
  }
  for (std::size_t n = 0; n < net.size(); ++n) net[n] += p2p[n];
  return net;
}

Ownership plan_ownership(const DeviceGraph& g, const std::vector<Bytes>& block_bytes, OwnershipOptions opt) {
  Ownership o;
  const std::size_t nn = g.nodes.size();
  o.group_of_node.assign(nn, -1);
  o.host_of_node.assign(nn, kNone);
  const std::vector<double> w = node_ray_throughput(g);
  std::vector<double> cap(nn, 0.0), whole(nn, 0.0);  // owned-block room; all compute memories
  std::vector<NodeId> nodes;
  for (std::size_t n = 0; n < nn; ++n) {
    for (DeviceId d : g.nodes[n].computes) {
      const MemId m = g.computes[d].memory;
      if (g.memories[m].kind == MemoryKind::Host && o.host_of_node[n] == kNone) o.host_of_node[n] = m;
    }
    if (g.nodes[n].computes.empty() || w[n] <= 0) continue;
    for (MemId m : g.nodes[n].memories)
      if (g.memories[m].kind != MemoryKind::Disk && !g.computes_on(m).empty())
        whole[n] += static_cast<double>(g.memories[m].capacity);
    if (o.host_of_node[n] == kNone) o.host_of_node[n] = g.computes[g.nodes[n].computes[0]].memory;  // GPU-only node
    const MemId home = o.host_of_node[n];
    cap[n] = opt.host_share * static_cast<double>(g.memories[home].capacity);
    for (MemId m : g.nodes[n].memories)  // GPU memory holds owned blocks too (its GPU runs them)
      if (m != home && g.memories[m].kind == MemoryKind::Gpu && !g.computes_on(m).empty())
        cap[n] += opt.gpu_share * static_cast<double>(g.memories[m].capacity);
    nodes.push_back(static_cast<NodeId>(n));
  }
  const double scene = static_cast<double>(std::accumulate(block_bytes.begin(), block_bytes.end(), Bytes{0}));
  // Nodes whose memories hold (nearly) the whole scene replicate it: a group each.
  std::vector<bool> alone(nn, false);
  std::vector<NodeId> pooled;
  o.weight.assign(nn, 0.0);
  for (NodeId n : nodes) {
    const auto i = static_cast<std::size_t>(n);
    alone[i] = whole[i] >= opt.replicate_fraction * scene;
    if (alone[i]) {
      o.groups.push_back({n});
      o.weight[i] = w[i];
    } else {
      pooled.push_back(n);
    }
  }
  if (!pooled.empty()) {
    // The others split the scene: weights capped by the LAN; a node left with too little
    // of its throughput takes part in no group.
    const std::vector<double> lan = node_lan_bandwidth(g);
    std::vector<NodeId> owners;
    for (NodeId n : pooled) {
      const auto i = static_cast<std::size_t>(n);
      o.weight[i] = std::min(w[i], opt.lan_reuse * lan[i]);
      if (o.weight[i] >= opt.min_lan_fraction * w[i]) owners.push_back(n);
      else o.weight[i] = 0;
    }
    if (owners.empty() && o.groups.empty()) {  // every link too slow, and no replica: by throughput alone
      owners = pooled;
      for (NodeId n : pooled) o.weight[static_cast<std::size_t>(n)] = w[static_cast<std::size_t>(n)];
    }
    // As many groups as the memories allow: nodes by decreasing room, each to the group
    // with the least room so far; fewer groups until every group holds the scene.
    std::stable_sort(owners.begin(), owners.end(),
                     [&](NodeId a, NodeId b) { return cap[static_cast<std::size_t>(a)] > cap[static_cast<std::size_t>(b)]; });
    double room = 0;
    for (NodeId n : owners) room += cap[static_cast<std::size_t>(n)];
    std::size_t count = scene > 0 ? static_cast<std::size_t>(room / scene) : owners.size();
    count = std::clamp<std::size_t>(count, 1, std::max<std::size_t>(1, owners.size()));
    for (; !owners.empty(); --count) {
      std::vector<std::vector<NodeId>> groups(count);
      std::vector<double> held(count, 0.0);
      for (NodeId n : owners) {
        const std::size_t k = static_cast<std::size_t>(std::min_element(held.begin(), held.end()) - held.begin());
        groups[k].push_back(n);
        held[k] += cap[static_cast<std::size_t>(n)];
      }
      if (count == 1 || *std::min_element(held.begin(), held.end()) >= scene) {
        for (auto& gr : groups) {
          std::sort(gr.begin(), gr.end());
          o.groups.push_back(std::move(gr));
        }
        break;
      }
    }
  }
  for (std::size_t k = 0; k < o.groups.size(); ++k) {
    std::vector<double> gw, gc;
    for (NodeId n : o.groups[k]) {
      const auto i = static_cast<std::size_t>(n);
      o.group_of_node[i] = static_cast<int>(k);
      gw.push_back(o.weight[i]);
      gc.push_back(alone[i] ? scene : cap[i]);
    }
    o.owner.push_back(split_blocks(o.groups[k], gw, gc, block_bytes));
  }
  return o;
}

std::vector<std::vector<MemId>> ownership_warm_placement(const Ownership& o, const DeviceGraph& g,
                                                         const std::vector<Bytes>& block_bytes, double host_share,
                                                         double gpu_share) {
  if (o.replicated()) return {};
  std::vector<std::vector<MemId>> at(block_bytes.size());
  std::vector<double> used(g.memories.size(), 0.0);
  auto put = [&](std::size_t b, MemId m, double share) {
    const double room = share * static_cast<double>(g.memories[static_cast<std::size_t>(m)].capacity);
    if (used[static_cast<std::size_t>(m)] + static_cast<double>(block_bytes[b]) > room) return;
    used[static_cast<std::size_t>(m)] += static_cast<double>(block_bytes[b]);
    at[b].push_back(m);
  };
  // Host memory first, in block order; then the GPU memories take what the host could not
  // hold (those blocks have no other copy near a device), then the rest while they fit.
  for (const std::vector<NodeId>& owner : o.owner) {
    std::vector<bool> in_host(block_bytes.size(), false);
    for (std::size_t b = 0; b < block_bytes.size(); ++b) {
      const NodeId n = owner[b];
      if (n == kNone) continue;
      const MemId host = o.host_of_node[static_cast<std::size_t>(n)];
      const std::size_t before = at[b].size();
      if (host != kNone) put(b, host, g.memories[static_cast<std::size_t>(host)].kind == MemoryKind::Gpu ? gpu_share : host_share);
      in_host[b] = at[b].size() > before;
    }
    for (const bool overflow : {true, false})
      for (std::size_t b = 0; b < block_bytes.size(); ++b) {
        const NodeId n = owner[b];
        if (n == kNone || in_host[b] != !overflow) continue;
        for (MemId m : g.nodes[static_cast<std::size_t>(n)].memories)
          if (m != o.host_of_node[static_cast<std::size_t>(n)] && g.memories[static_cast<std::size_t>(m)].kind == MemoryKind::Gpu &&
              !g.computes_on(m).empty())
            put(b, m, gpu_share);
      }
  }
  return at;
}

}  // namespace rayline
