#include "sched/fetch_bound.hpp"

#include <algorithm>

namespace rayline {

FetchBound::FetchBound(const DeviceGraph& g) : n_(g.memories.size()), in_resources_(g.memories.size()) {
  lat_.assign(n_ * n_, kNever);
  inv_bw_.assign(n_ * n_, kNever);
  for (std::size_t i = 0; i < n_; ++i) lat_[i * n_ + i] = inv_bw_[i * n_ + i] = 0;
  for (const Channel& c : g.channels) {
    const std::size_t k = static_cast<std::size_t>(c.from) * n_ + static_cast<std::size_t>(c.to);
    lat_[k] = std::min(lat_[k], c.latency);
    inv_bw_[k] = std::min(inv_bw_[k], 1.0 / c.bandwidth);
    auto& in = in_resources_[static_cast<std::size_t>(c.to)];
    for (ResourceId r : c.resources)
      if (std::find(in.begin(), in.end(), r) == in.end()) in.push_back(r);
  }
  for (std::size_t k = 0; k < n_; ++k)  // Floyd-Warshall, twice
    for (std::size_t i = 0; i < n_; ++i)
      for (std::size_t j = 0; j < n_; ++j) {
        lat_[i * n_ + j] = std::min(lat_[i * n_ + j], lat_[i * n_ + k] + lat_[k * n_ + j]);
        inv_bw_[i * n_ + j] = std::min(inv_bw_[i * n_ + j], inv_bw_[i * n_ + k] + inv_bw_[k * n_ + j]);
      }
}

FetchBound::Memos& FetchBound::memo(BlockId b, MemId m) const {
  const auto bi = static_cast<std::size_t>(b);
  if (bi >= slot_of_block_.size()) slot_of_block_.resize(std::max(2 * slot_of_block_.size(), bi + 1), -1);
  if (slot_of_block_[bi] < 0) {
    slot_of_block_[bi] = static_cast<std::int32_t>(memos_.size() / n_);
    memos_.resize(memos_.size() + n_);
  }
  return memos_[static_cast<std::size_t>(slot_of_block_[bi]) * n_ + static_cast<std::size_t>(m)];
}

std::uint64_t FetchBound::in_stamp(const Schedule& s, MemId m) const {
  std::uint64_t v = 0;
  for (ResourceId r : in_resources_[static_cast<std::size_t>(m)]) v += s.resource_version(r);
  return v;
}

Time FetchBound::lower_bound(const Schedule& s, BlockId b, MemId m, Time now) const {
  Memo& e = memo(b, m).lower;
  const std::uint64_t hv = s.holders_version(b), in = in_stamp(s, m);
  if (e.epoch == epoch_ && e.holders == hv && e.in == in) return e.value;
  e.value = lower_bound_uncached(s, b, m, now, true);
  e.holders = hv;
  e.in = in;
  e.epoch = epoch_;
  return e.value;
}

Time FetchBound::lower_bound_once(const Schedule& s, BlockId b, MemId m, Time now) const {
  return lower_bound_uncached(s, b, m, now, false);
}

Time FetchBound::lower_bound_uncached(const Schedule& s, BlockId b, MemId m, Time now, bool memoised_holders) const {
  if (const Copy* c = s.copy_at(b, m)) return std::max(now, s.copy_ready(*c));
  const DeviceGraph& g = s.graph();
  const Bytes bytes = s.pool().block(b).bytes;
  Time best = kNever;
  for (ChannelId c : g.in_channels(m)) {
    const Time at_src = memoised_holders ? holders_bound(s, b, g.channels[c].from, now)
                                         : holders_bound_uncached(s, b, g.channels[c].from, now);
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
  Memo& e = memo(b, m).holders;
  const std::uint64_t hv = s.holders_version(b);
  if (e.epoch == epoch_ && e.holders == hv) return e.value;
  e.value = holders_bound_uncached(s, b, m, now);
  e.holders = hv;
  e.epoch = epoch_;
  return e.value;
}

Time FetchBound::holders_bound_uncached(const Schedule& s, BlockId b, MemId m, Time now) const {
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
