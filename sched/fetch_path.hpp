// Smallest Datapath Contention (SDC, Sec. 4.4, Eq. 3): the earliest time a data block can
// reach each memory device given the current schedule. Dijkstra from a virtual source S
// joined to every holder m of the block by an edge weighted with the copy's ready time;
// relaxing channel c_pq gives
//     l_{S->q} = max(l_{S->p}, FinishTime(c_pq)) + T_TRANS(c_pq, |w|)        (Eq. 3)
// One run yields a shortest-path tree to every memory device, so results are cached per
// block and invalidated only by what a commit changes: the block's holders (versioned by
// the Schedule), or the busy-until of a resource on the path to a destination. Each
// destination keeps the sum of the Schedule's resource versions along its path at search
// time; versions only grow, so the destination is still valid iff the sum is unchanged
// (no reverse index, nothing to push: a commit invalidates exactly the destinations whose
// path crosses a resource it booked). Within one planning pass costs never decrease, so a
// path none of whose edges changed stays optimal.
//
// Capacity is not part of the search (it would invalidate every tree reaching the
// memory device that just received data); the scheduler applies admission delays when it
// commits the hops. Memory devices smaller than the block are skipped.
#pragma once
#include <vector>

#include "schedule.hpp"

namespace rayline {

class FetchPathFinder {
 public:
  explicit FetchPathFinder(const Schedule& schedule);

  // Earliest arrival of block b at m; kNever when no path (or b has no holder).
  Time arrival(BlockId b, MemId m);
  // Channels of the best path to m, source first (empty if b is already on m).
  void path(BlockId b, MemId m, std::vector<ChannelId>& out);

  // After a T-job was appended on r. Kept for callers; validity is read from the
  // Schedule's resource versions, so this has nothing left to do.
  void resource_changed(ResourceId) {}
  void clear();                         // after reproject(): everything may have moved
  // Transfers cannot start in the past: a holder's edge from S weighs max(ready, now).
  void set_now(Time now) { if (now != now_) { now_ = now; clear(); } }
  // Baselines that never send scene data between nodes (GraviT compiles SEND_DOMS out):
  // SceneData then starts from the destination node's own copies when it has any, else
  // from origin copies (a central scene database), never from another node's cache.
  void set_scene_from_origin_or_local(bool on) {
    if (on != scene_local_) { scene_local_ = on; clear(); }
  }
  bool scene_from_origin_or_local() const { return scene_local_; }

  std::uint64_t searches() const { return searches_; }
  std::uint64_t hits() const { return hits_; }

 private:
  struct Tree {
    bool valid = false;
    std::uint64_t holders_version = 0;
    std::vector<Time> arrival;         // per memory device
    std::vector<ChannelId> via;        // incoming tree channel per memory device (kNone at roots)
    std::vector<std::uint64_t> stamp;  // per memory device: sum of resource versions on its path
    NodeId node = kNone;               // scene_local_: the node the roots were restricted to
  };
  Tree& tree(BlockId b, MemId m);
  NodeId restrict_node_ = kNone;  // with scene_local_: the destination's node
  void search(BlockId b, Tree& t);
  std::uint64_t path_stamp(const Tree& t, MemId m) const;
  std::uint64_t channel_stamp(ChannelId c) const;

  const Schedule* schedule_;
  std::vector<Tree> trees_;
  std::vector<std::pair<Time, MemId>> heap_;
  std::vector<char> done_, holder_;
  std::uint64_t searches_ = 0, hits_ = 0;
  Time now_ = 0;
  bool scene_local_ = false;
};

}  // namespace rayline
