#include "sched/fetch_path.hpp"

#include <algorithm>

namespace rayline {

FetchPathFinder::FetchPathFinder(const Schedule& schedule)
    : schedule_(&schedule), users_of_resource_(schedule.graph().resources.size()) {}

void FetchPathFinder::clear() {
  for (Tree& t : trees_) t.valid = false;
  for (auto& u : users_of_resource_) u.clear();
}

void FetchPathFinder::resource_changed(ResourceId r) {
  for (auto [b, m] : users_of_resource_[r]) trees_[b].dest_valid[m] = 0;
  users_of_resource_[r].clear();
}

FetchPathFinder::Tree& FetchPathFinder::tree(BlockId b, MemId m) {
  if (static_cast<std::size_t>(b) >= trees_.size()) trees_.resize(schedule_->pool().block_count());
  Tree& t = trees_[b];
  const bool restricted = scene_local_ && schedule_->pool().block(b).kind == DataKind::SceneData;
  restrict_node_ = restricted ? schedule_->graph().memories[m].node : kNone;
  if (t.valid && t.dest_valid[m] && t.holders_version == schedule_->holders_version(b) && t.node == restrict_node_) {
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
  t.dest_valid.assign(nm, 1);
  for (std::size_t m = 0; m < nm; ++m)
    for (MemId q = static_cast<MemId>(m); t.via[q] != kNone; q = g.channels[t.via[q]].from)
      for (ResourceId r : g.channels[t.via[q]].resources) users_of_resource_[r].emplace_back(b, static_cast<MemId>(m));
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
