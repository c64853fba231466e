#include "sched/policy/gmb/arrival_bound.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

namespace rayline {

ArrivalBound::ArrivalBound(const DeviceGraph& g) : n_(g.memories.size()), min_inv_bw_in_(g.memories.size(), kNever) {
  for (const Channel& c : g.channels) {
    double& v = min_inv_bw_in_[static_cast<std::size_t>(c.to)];
    v = std::min(v, 1.0 / c.bandwidth);
  }
}

void ArrivalBound::reset(Time now) {
  ++epoch_;
  // Records are valid for their pass only: the slots are given out again from the start
  // (a long run asks about hundreds of thousands of blocks, a pass about a few hundred).
  for (BlockId b : slotted_) blocks_[static_cast<std::size_t>(b)].slot = -1;
  slotted_.clear();
  own_.clear();
  now_ = now;
  n_groups_ = 0;
  sigs_.clear();
  std::fill(table_.begin(), table_.end(), -1);
}

// FNV-1a over the signature's values (times by value: +0 and -0 are the same root weight).
std::uint64_t ArrivalBound::hash(const std::vector<std::pair<std::int64_t, Time>>& sig) {
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](std::uint64_t v) {
    h ^= v;
    h *= 1099511628211ull;
  };
  for (const auto& [mem, t] : sig) {
    mix(static_cast<std::uint64_t>(mem));
    mix(t == 0 ? 0 : std::bit_cast<std::uint64_t>(t));
  }
  return h;
}

// The group whose signature equals sig_ (values compared with ==), created if new: ids in
// order of first appearance.
std::int32_t ArrivalBound::find_or_add_group(std::uint64_t h) {
  if (table_.size() < 2 * (n_groups_ + 1)) {  // grow (and rehash) to a load of at most 1/2
    table_.assign(std::bit_ceil(std::max<std::size_t>(64, 4 * (n_groups_ + 1))), -1);
    for (std::size_t g = 0; g < n_groups_; ++g) {
      std::size_t k = groups_[g].hash & (table_.size() - 1);
      while (table_[k] >= 0) k = (k + 1) & (table_.size() - 1);
      table_[k] = static_cast<std::int32_t>(g);
    }
  }
  // (table_.size() is a power of two.)
  std::size_t k = h & (table_.size() - 1);
  for (; table_[k] >= 0; k = (k + 1) & (table_.size() - 1)) {
    const Group& grp = groups_[static_cast<std::size_t>(table_[k])];
    if (grp.hash == h && grp.sig_size == sig_.size() && std::equal(sig_.begin(), sig_.end(), sigs_.begin() + static_cast<std::ptrdiff_t>(grp.sig_at)))
      return table_[k];
  }
  const auto g = static_cast<std::int32_t>(n_groups_++);
  table_[k] = g;
  if (groups_.size() < n_groups_) groups_.emplace_back();
  Group& grp = groups_[static_cast<std::size_t>(g)];
  grp.members.clear();
  // (Records of an earlier pass are of an earlier epoch: not valid(), nothing to clear.)
  if (grp.largest.size() != n_) grp.largest.assign(n_, Rec{});
  grp.first = 0;
  grp.unsorted = false;
  grp.version = 0;
  grp.hash = h;
  grp.sig_at = sigs_.size();
  grp.sig_size = sig_.size();
  sigs_.insert(sigs_.end(), sig_.begin(), sig_.end());
  return g;
}

// The class of blocks with exactly b's SDC sources: movability, and every holder with its
// root weight max(now, ready) (fetch_path.cpp).
std::int32_t ArrivalBound::assign(const Schedule& s, BlockId b) { return assign(s, b, true); }

void ArrivalBound::assign_all(const Schedule& s, std::span<const BlockId> blocks) {
  touched_groups_.clear();
  for (BlockId b : blocks) assign(s, b, false);
  // Each group's members sorted once: the same ordered set that inserting one by one builds.
  for (const std::int32_t g : touched_groups_) {
    Group& grp = groups_[static_cast<std::size_t>(g)];
    std::sort(grp.members.begin(), grp.members.end());
    grp.members.erase(std::unique(grp.members.begin(), grp.members.end()), grp.members.end());
    grp.first = 0;
    grp.unsorted = false;
  }
}

std::int32_t ArrivalBound::assign(const Schedule& s, BlockId b, bool sorted) {
  if (static_cast<std::size_t>(b) >= blocks_.size()) blocks_.resize(s.pool().block_count());
  BlockState& bs = blocks_[static_cast<std::size_t>(b)];
  const std::uint64_t hv = s.holders_version(b);
  if (bs.epoch == epoch_ && bs.holders == hv) return bs.group;
  if (bs.epoch == epoch_ && bs.group >= 0) ++groups_[static_cast<std::size_t>(bs.group)].version;  // b leaves it
  // The same copies, in the same order, as the block assigned last: the same signature
  // (assign_all(): a pass starts with every scene block on the same disks).
  const std::vector<Copy>& copies = s.copies(b);
  const bool movable = s.pool().block(b).movable;
  const auto same_as_last = [&] {
    if (last_ == kNone || last_epoch_ != epoch_ || group(s, last_) != last_group_ || s.pool().block(last_).movable != movable)
      return false;
    const std::vector<Copy>& lc = s.copies(last_);
    if (lc.size() != copies.size()) return false;
    for (std::size_t k = 0; k < copies.size(); ++k)
      if (lc[k].mem != copies[k].mem || std::max(now_, s.copy_ready(lc[k])) != std::max(now_, s.copy_ready(copies[k]))) return false;
    return true;
  };
  std::int32_t id = last_group_;
  if (!same_as_last()) {
    sig_.clear();
    sig_.emplace_back(-1, movable ? 1.0 : 0.0);
    // Sorted by memory device (one copy per device, so the weights never decide): a block
    // with many copies (a scene block on every disk) is read in that order from its
    // position index, without a sort.
    if (const std::int32_t* pos = s.copy_positions(b)) {
      for (std::size_t m = 0; m < n_; ++m)
        if (pos[m] >= 0) sig_.emplace_back(static_cast<std::int64_t>(m), std::max(now_, s.copy_ready(copies[static_cast<std::size_t>(pos[m])])));
    } else {
      for (const Copy& c : copies) sig_.emplace_back(c.mem, std::max(now_, s.copy_ready(c)));
      std::sort(sig_.begin() + 1, sig_.end());
    }
    id = find_or_add_group(hash(sig_));
  }
  last_ = b;
  last_group_ = id;
  last_epoch_ = epoch_;
  Group& grp = groups_[static_cast<std::size_t>(id)];
  auto& mem = grp.members;
  const std::pair<Bytes, BlockId> me{s.pool().block(b).bytes, b};
  if (!sorted) {  // assign_all(): appended now, sorted at its end
    if (!grp.unsorted) touched_groups_.push_back(id);
    grp.unsorted = true;
    mem.push_back(me);
    bs.group = id;
    bs.holders = hv;
    bs.epoch = epoch_;
    return id;
  }
  const auto pos = std::lower_bound(mem.begin(), mem.end(), me);
  grp.first = std::min(grp.first, static_cast<std::size_t>(pos - mem.begin()));
  if (pos == mem.end() || *pos != me) mem.insert(pos, me);
  bs.group = id;
  bs.holders = hv;
  bs.epoch = epoch_;
  return bs.group;
}

void ArrivalBound::record(const Schedule& s, BlockId b, MemId m, Time lb) {
  if (static_cast<std::size_t>(b) >= blocks_.size()) blocks_.resize(s.pool().block_count());
  BlockState& bs = blocks_[static_cast<std::size_t>(b)];
  if (bs.slot < 0) {
    bs.slot = static_cast<std::int32_t>(own_.size() / n_);
    own_.resize(own_.size() + n_);
    slotted_.push_back(b);
  }
  const Rec r{lb, b, s.pool().block(b).bytes, s.holders_version(b), epoch_};
  own_[static_cast<std::size_t>(bs.slot) * n_ + static_cast<std::size_t>(m)] = r;
  const std::int32_t g = group(s, b);
  if (g == kNone) return;
  ++groups_[static_cast<std::size_t>(g)].version;
  Rec& big = groups_[static_cast<std::size_t>(g)].largest[static_cast<std::size_t>(m)];
  if (!valid(s, big) || group(s, big.block) != g || big.bytes < r.bytes || big.block == b) big = r;
}

[[gnu::always_inline]] inline Time ArrivalBound::from(const Rec& r, Bytes bytes, MemId m) const {
  if (r.at == kNever) return kNever;  // a larger block fits through no more memory devices
  if (bytes == r.bytes) return r.at;
  Time inc = static_cast<double>(bytes - r.bytes) * min_inv_bw_in_[static_cast<std::size_t>(m)] * (1 - 1e-9);
  if (!(inc >= 0 && inc < kNever)) inc = 0;
  // Real-arithmetic bound, less a margin for the rounding of both searches (far below
  // 1e-14 relative on paths of a few hops) and of the increment itself.
  return r.at + inc - 2e-14 * std::max(1.0, std::abs(r.at));
}

Time ArrivalBound::bound(const Schedule& s, BlockId b, MemId m) const {
  const std::int32_t g = group(s, b);
  return bound(s, b, m, g, g == kNone ? kNone : smallest(s, g));
}

Time ArrivalBound::bound(const Schedule& s, BlockId b, MemId m, std::int32_t g, BlockId first) const {
  Time lb = -std::numeric_limits<Time>::infinity();
  if (static_cast<std::size_t>(b) >= blocks_.size()) return lb;
  const BlockState& bs = blocks_[static_cast<std::size_t>(b)];
  if (bs.slot >= 0) {
    const Rec& own = own_[static_cast<std::size_t>(bs.slot) * n_ + static_cast<std::size_t>(m)];
    if (valid(s, own)) lb = own.at;
  }
  if (g == kNone) return lb;
  // A holder's arrival is its copy's ready time: the same for every member.
  if (s.copy_at(b, m)) return lb;
  const Bytes bytes = s.pool().block(b).bytes;
  const Rec& big = groups_[static_cast<std::size_t>(g)].largest[static_cast<std::size_t>(m)];
  if (valid(s, big) && group(s, big.block) == g && big.bytes <= bytes) lb = std::max(lb, from(big, bytes, m));
  if (first != kNone && first != b) {
    const BlockState& fs = blocks_[static_cast<std::size_t>(first)];
    if (fs.slot >= 0) {
      const Rec& r = own_[static_cast<std::size_t>(fs.slot) * n_ + static_cast<std::size_t>(m)];
      if (valid(s, r)) lb = std::max(lb, from(r, bytes, m));
    }
  }
  return lb;
}

}  // namespace rayline
