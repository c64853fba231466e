#include "sched/fetch_bound.hpp"

#include <algorithm>

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
  for (std::size_t k = 0; k < n_; ++k)  // Floyd-Warshall, twice
    for (std::size_t i = 0; i < n_; ++i)
      for (std::size_t j = 0; j < n_; ++j) {
        lat_[i * n_ + j] = std::min(lat_[i * n_ + j], lat_[i * n_ + k] + lat_[k * n_ + j]);
        inv_bw_[i * n_ + j] = std::min(inv_bw_[i * n_ + j], inv_bw_[i * n_ + k] + inv_bw_[k * n_ + j]);
      }
}

Time FetchBound::lower_bound(const Schedule& s, BlockId b, MemId m, Time now) const {
  if (const Copy* c = s.copy_at(b, m)) return std::max(now, s.copy_ready(*c));
  const DeviceGraph& g = s.graph();
  const Bytes bytes = s.pool().block(b).bytes;
  Time best = kNever;
  for (ChannelId c : g.in_channels(m)) {
    const Time at_src = holders_bound(s, b, g.channels[c].from, now);
    if (at_src == kNever) continue;
    best = std::min(best, std::max(at_src, s.channel_finish(c)) + g.transfer_time(c, bytes));
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
      for (ChannelId c2 : g.out_channels(p))
        if (g.channels[c2].to == m) best = std::min(best, std::max(t1, s.channel_finish(c2)) + g.transfer_time(c2, bytes));
    }
  return best;
}

Time FetchBound::holders_bound(const Schedule& s, BlockId b, MemId m, Time now) const {
  const double bytes = static_cast<double>(s.pool().block(b).bytes);
  Time best = kNever;
  for (const Copy& c : s.copies(b)) {
    const Time ready = std::max(now, s.copy_ready(c));
    if (c.mem == m) return ready;
    const std::size_t k = static_cast<std::size_t>(c.mem) * n_ + static_cast<std::size_t>(m);
    best = std::min(best, ready + lat_[k] + bytes * inv_bw_[k]);
  }
  return best;
}

}  // namespace rayline
