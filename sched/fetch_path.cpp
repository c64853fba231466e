#include "sched/fetch_path.hpp"

#include <algorithm>

namespace rayline {

FetchPathFinder::FetchPathFinder(const Schedule& schedule) : schedule_(&schedule) {}

void FetchPathFinder::clear() {
  for (Tree& t : trees_) t.valid = false;
}

std::uint64_t FetchPathFinder::channel_stamp(ChannelId c) const {
  std::uint64_t v = 0;
  for (ResourceId r : schedule_->graph().channels[c].resources) v += schedule_->resource_version(r);
  return v;
}

// Sum of the current versions of the resources on m's tree path (equal to the stamp taken
// at search time iff none of them was booked since: versions only grow).
std::uint64_t FetchPathFinder::path_stamp(const Tree& t, MemId m) const {
  const DeviceGraph& g = schedule_->graph();
  std::uint64_t v = 0;
  for (MemId q = m; t.via[q] != kNone; q = g.channels[t.via[q]].from) v += channel_stamp(t.via[q]);
  return v;
}

FetchPathFinder::Tree& FetchPathFinder::tree(BlockId b, MemId m) {
  if (static_cast<std::size_t>(b) >= trees_.size()) trees_.resize(schedule_->pool().block_count());
  Tree& t = trees_[b];
  const bool restricted = scene_local_ && schedule_->pool().block(b).kind == DataKind::SceneData;
  restrict_node_ = restricted ? schedule_->graph().memories[m].node : kNone;
  if (t.valid && t.holders_version == schedule_->holders_version(b) && t.node == restrict_node_ &&
      t.stamp[m] == path_stamp(t, m)) {
    ++hits_;
    return t;
  }
  search(b, t);
  return t;
}

void FetchPathFinder::search(BlockId b, Tree& t) {
  ++searches_;
  const DeviceGraph& g = schedule_->graph();
  const DataBlock& blk = schedule_->pool().block(b);
  const std::size_t nm = g.memories.size();
  t.arrival.assign(nm, kNever);
  t.via.assign(nm, kNone);
  t.stamp.assign(nm, 0);
  done_.assign(nm, 0);
  heap_.clear();
  auto cmp = [](const auto& a, const auto& c) { return a.first > c.first; };
  // Virtual source S: one edge per holder, weighted by the copy's ready time.
  holder_.assign(nm, 0);
  t.node = restrict_node_;
  // scene_local_: a rank loads from its own node when the node holds the block, else from
  // the storage that does (a central scene database); never from another node's cache.
  bool node_has_copy = false;
  if (restrict_node_ != kNone)
    for (const Copy& c : schedule_->copies(b)) node_has_copy = node_has_copy || g.memories[c.mem].node == restrict_node_;
  for (const Copy& c : schedule_->copies(b)) {
    holder_[c.mem] = 1;
    if (restrict_node_ != kNone) {
      const bool local = g.memories[c.mem].node == restrict_node_;
      if (node_has_copy ? !local : !c.origin) continue;
    }
    const Time r = std::max(now_, schedule_->copy_ready(c));
    if (r < t.arrival[c.mem]) {
      t.arrival[c.mem] = r;
      heap_.emplace_back(r, c.mem);
      std::push_heap(heap_.begin(), heap_.end(), cmp);
    }
  }
  if (blk.movable) {
    while (!heap_.empty()) {
      std::pop_heap(heap_.begin(), heap_.end(), cmp);
      const auto [lp, p] = heap_.back();
      heap_.pop_back();
      if (done_[p]) continue;
      done_[p] = 1;
      // p's tree path is final now, and its parent's stamp was taken before.
      if (t.via[p] != kNone) t.stamp[p] = t.stamp[g.channels[t.via[p]].from] + channel_stamp(t.via[p]);
      for (ChannelId c : g.out_channels(p)) {
        const MemId q = g.channels[c].to;
        // A holder never receives a second copy (its own copy may still be in flight).
        if (done_[q] || holder_[q] || g.memories[q].capacity < blk.bytes) continue;
        const Time lq = std::max(lp, schedule_->channel_finish(c)) + g.transfer_time(c, blk.bytes);  // Eq. 3
        if (lq < t.arrival[q]) {
          t.arrival[q] = lq;
          t.via[q] = c;
          heap_.emplace_back(lq, q);
          std::push_heap(heap_.begin(), heap_.end(), cmp);
        }
      }
    }
  }
  t.valid = true;
  t.holders_version = schedule_->holders_version(b);
}

Time FetchPathFinder::arrival(BlockId b, MemId m) { return tree(b, m).arrival[m]; }

void FetchPathFinder::path(BlockId b, MemId m, std::vector<ChannelId>& out) {
  out.clear();
  const Tree& t = tree(b, m);
  if (t.arrival[m] == kNever) return;
  const DeviceGraph& g = schedule_->graph();
  for (MemId q = m; t.via[q] != kNone; q = g.channels[t.via[q]].from) out.push_back(t.via[q]);
  std::reverse(out.begin(), out.end());
}

}  // namespace rayline
