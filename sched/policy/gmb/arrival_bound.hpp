// Lower bounds on SDC arrivals (Sec. 4.4, Eq. 3) from arrivals already computed, for
// ordering and pruning GMB's job selection (gmb_scheduler.cpp; planning speed):
//   * the block's own last exact arrival at m: within a planning pass channels only get
//     busier, so while the block's holders are unchanged its arrival can only grow;
//   * holder groups: blocks with the same sources (same memory devices, same ready
//     times, same movability; e.g. scene blocks still only on the disks) have arrivals
//     monotone in |w|. Along any path Eq. 3 is monotone in |w|, the last hop c into m
//     adds |w|/T_BW(c), and a larger block fits through no more memory devices, so
//         arrival(b, m) >= arrival(b', m) + (|b| - |b'|) / max_c T_BW(c)    for |b'| <= |b|.
//     Scanning a group smallest first, the first block whose arrival loses to the best
//     job found rules out every larger one without a search.
// Groups are assigned eagerly: the scheduler reports every block whose holders change
// (assign()). Every bound is checked against the Schedule's holders versions, so a block
// not reported is merely bounded less tightly. The bounds only order and prune; a job's
// start is always computed exactly (fetch_path.hpp) before it can be chosen.
#pragma once
#include <span>
#include <vector>

#include "sched/timeline/schedule.hpp"

namespace rayline {

class ArrivalBound {
 public:
  explicit ArrivalBound(const DeviceGraph& g);
  void reset(Time now);  // a new planning pass (after reproject())
  // b's holders changed, or b is new: (re)compute its group; returns it.
  std::int32_t assign(const Schedule& s, BlockId b);
  // assign() for each of `blocks` (a new pass: in that order, so group ids are the same),
  // each group's members sorted once at the end instead of inserted one by one.
  void assign_all(const Schedule& s, std::span<const BlockId> blocks);
  // b's group if it is still current (kNone otherwise).
  std::int32_t group(const Schedule& s, BlockId b) const {
    if (static_cast<std::size_t>(b) >= blocks_.size()) return kNone;
    const BlockState& bs = blocks_[static_cast<std::size_t>(b)];
    return bs.epoch == epoch_ && bs.holders == s.holders_version(b) ? bs.group : kNone;
  }
  std::size_t group_count() const { return n_groups_; }
  // Members of g, smallest first; may list blocks that left since (group(b) != g).
  const std::vector<std::pair<Bytes, BlockId>>& members(std::int32_t g) const { return groups_[static_cast<std::size_t>(g)].members; }
  BlockId smallest(const Schedule& s, std::int32_t g) const {  // kNone if none is current
    const Group& grp = groups_[static_cast<std::size_t>(g)];
    const std::size_t k = first_current(s, g);
    return k < grp.members.size() ? grp.members[k].second : kNone;
  }
  // Counts what can raise g's bounds: a record for a member, a member leaving. A key
  // computed from them (GmbScheduler::group_key) is as tight as a new one while it stays.
  std::uint64_t version(std::int32_t g) const { return groups_[static_cast<std::size_t>(g)].version; }
  // Index in members(g) of its smallest current member (members().size() if none).
  std::size_t first_current(const Schedule& s, std::int32_t g) const {
    const Group& grp = groups_[static_cast<std::size_t>(g)];
    while (grp.first < grp.members.size() && group(s, grp.members[grp.first].second) != g) ++grp.first;
    return grp.first;
  }
  // `lb` is at most the SDC arrival of b at m at this point of the plan.
  void record(const Schedule& s, BlockId b, MemId m, Time lb);
  // A lower bound on the SDC arrival of b at m from the records; -inf if none applies.
  Time bound(const Schedule& s, BlockId b, MemId m) const;
  // The same, given b's current group g (kNone: none) and g's smallest current member
  // (smallest(s, g)), for a caller scanning g's members.
  Time bound(const Schedule& s, BlockId b, MemId m, std::int32_t g, BlockId first) const;

 private:
  struct Rec {
    Time at = 0;
    BlockId block = kNone;
    Bytes bytes = 0;
    std::uint64_t holders = 0;  // holders_version(block) when recorded
    std::uint64_t epoch = 0;
  };
  struct BlockState {
    std::int32_t slot = -1;     // into own_ (n_ entries), once recorded
    std::int32_t group = -1;
    std::uint64_t holders = 0;  // holders_version(b) the group was computed for
    std::uint64_t epoch = 0;    // reset() count of `group`
  };
  struct Group {
    std::vector<std::pair<Bytes, BlockId>> members;
    std::vector<Rec> largest;  // per memory device: the largest member with a record
    // No member before this index is current (members leave lazily; one that joins again
    // moves it back).
    mutable std::size_t first = 0;
    std::uint64_t hash = 0;       // of its signature,
    std::size_t sig_at = 0, sig_size = 0;  // sigs_[sig_at, sig_at + sig_size)
    bool unsorted = false;  // inside assign_all(): members appended, not yet sorted
    std::uint64_t version = 0;
  };
  std::int32_t assign(const Schedule& s, BlockId b, bool sorted);
  std::vector<std::int32_t> touched_groups_;  // assign_all(): groups with appended members
  BlockId last_ = kNone;  // the block assign() placed last, its group, in which pass
  std::int32_t last_group_ = -1;
  std::uint64_t last_epoch_ = 0;
  bool valid(const Schedule& s, const Rec& r) const {
    return r.epoch == epoch_ && r.block != kNone && r.holders == s.holders_version(r.block);
  }
  Time from(const Rec& r, Bytes bytes, MemId m) const;  // r's bound carried to a block of `bytes`

  std::size_t n_;
  std::vector<double> min_inv_bw_in_;  // per memory device: 1 / the fastest incoming channel
  std::uint64_t epoch_ = 1;
  Time now_ = 0;
  std::vector<BlockState> blocks_;
  std::vector<Rec> own_;
  std::vector<BlockId> slotted_;  // the blocks with a slot in own_ this pass
  // Groups of this pass: groups_[0, n_groups_) (the vector keeps earlier passes' groups,
  // and their members' capacity, for reuse). Their signatures, concatenated, and an
  // open-addressing table from a signature's hash to its group (-1: empty slot).
  std::vector<Group> groups_;
  std::size_t n_groups_ = 0;
  std::vector<std::pair<std::int64_t, Time>> sigs_;
  std::vector<std::int32_t> table_;
  std::vector<std::pair<std::int64_t, Time>> sig_;
  static std::uint64_t hash(const std::vector<std::pair<std::int64_t, Time>>& sig);
  std::int32_t find_or_add_group(std::uint64_t h);  // for sig_
};

}  // namespace rayline
