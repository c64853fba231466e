#include "sched/sdc/fetch_path.hpp"

#include <algorithm>
#include <limits>

namespace rayline {

FetchPathFinder::FetchPathFinder(const Schedule& schedule)
    : schedule_(&schedule),
      n_(schedule.graph().memories.size()),
      done_(n_),
      holder_(n_, 0),
      label_(n_, kNever),
      label_via_(n_, kNone),
      tie_(n_, 0) {
  open_.reserve(4 * n_ + 8);
  touched_.reserve(4 * n_ + 8);
  build_hops();
}

void FetchPathFinder::build_hops() {
  const DeviceGraph& g = schedule_->graph();
  hops_.clear();
  hops_at_.assign(n_ + 1, 0);
  // Per memory device q: the largest capacity among the devices its channels lead to, and
  // the largest among those other than that device (q's onward capacity seen from p is
  // the first unless p is its device).
  struct Onward {
    Bytes first = 0, second = 0;
    MemId first_to = kNone;
  };
  std::vector<Onward> onward_of(n_);
  for (std::size_t q = 0; q < n_; ++q) {
    Onward& o = onward_of[q];
    for (const ChannelId c : g.out_channels(static_cast<MemId>(q))) {
      const MemId t = g.channels[static_cast<std::size_t>(c)].to;
      const Bytes cap = g.memories[static_cast<std::size_t>(t)].capacity;
      if (t == o.first_to) {
        o.first = std::max(o.first, cap);
      } else if (o.first_to == kNone || cap > o.first) {
        o.second = std::max(o.second, o.first);
        o.first = cap;
        o.first_to = t;
      } else {
        o.second = std::max(o.second, cap);
      }
    }
  }
  for (std::size_t p = 0; p < n_; ++p) {
    hops_at_[p] = static_cast<std::uint32_t>(hops_.size());
    for (const ChannelId c : g.out_channels(static_cast<MemId>(p))) {
      const Channel& ch = g.channels[static_cast<std::size_t>(c)];
      const Onward& o = onward_of[static_cast<std::size_t>(ch.to)];
      const Bytes onward = o.first_to != ch.from ? o.first : o.second;
      hops_.push_back({c, ch.to, g.memories[static_cast<std::size_t>(ch.to)].capacity, onward, ch.latency, ch.bandwidth});
    }
  }
  hops_at_[n_] = static_cast<std::uint32_t>(hops_.size());
  build_runs();
}

// Network runs (cut_search()): the channels of one network out of p to one group's members,
// consecutive in p's hops, with what NetworkFloor needs (FetchBound's groups).
void FetchPathFinder::build_runs() {
  const DeviceGraph& g = schedule_->graph();
  runs_built_ = true;
  runs_.clear();
  for (Hop& hop : hops_) hop.run = -1;
  if (rest_) {
    std::vector<ChannelId> run_channels;
    for (std::size_t p = 0; p < n_; ++p) {
      const std::uint32_t end = hops_at_[p + 1];
      for (std::uint32_t h = hops_at_[p]; h < end;) {
        const std::int32_t k = g.channels[static_cast<std::size_t>(hops_[h].channel)].network;
        const std::int32_t group = k >= 0 ? rest_->group_of(k, hops_[h].to) : -1;
        std::uint32_t e = h + 1;
        run_channels.assign(1, hops_[h].channel);
        for (; group >= 0 && e < end; ++e) {
          const Channel& ch = g.channels[static_cast<std::size_t>(hops_[e].channel)];
          if (ch.network != k || rest_->group_of(k, ch.to) != group) break;
          run_channels.push_back(hops_[e].channel);
        }
        if (group >= 0 && e - h >= kMinRun) {
          hops_[h].run = static_cast<std::int32_t>(runs_.size());
          runs_.push_back({e - h, k, group, FetchBound::Span::of(g, run_channels)});
        }
        h = e;
      }
    }
  }
}

void FetchPathFinder::clear() {
  for (BlockId b : valid_trees_) trees_[static_cast<std::size_t>(b)].valid = false;
  valid_trees_.clear();
  // Tree slots too: no tree is valid after this, so the next pass hands its slots out again
  // (kept per block for the run, they grew by one slot of n_ entries per block ever
  // searched: ~90 MB in 12 s of a path-tracing run on 8 nodes, 61 kB a block at 1 024).
  for (BlockId b : tree_slotted_) trees_[static_cast<std::size_t>(b)].slot = -1;
  tree_slotted_.clear();
  slots_ = 0;
  // Only the slots this pass gave out: a long path-tracing run has ~10^5 blocks (every ray
  // queue is one), far more than a pass touches, and it plans thousands of times.
  for (BlockId b : slotted_) memo_slot_[static_cast<std::size_t>(b)] = -1;
  slotted_.clear();
  memo_index_.clear();
  memos_.clear();  // (keeps its capacity: a pass asks about as many as the last one)
}

void FetchPathFinder::rebind(const Schedule& schedule) {
  schedule_ = &schedule;
  if (schedule.graph().memories.size() != n_) {
    *this = FetchPathFinder(schedule);
    return;
  }
  build_hops();
  clear();
}

// b's memo for m, reset when b's holders changed since it was taken.
FetchPathFinder::Memo& FetchPathFinder::memo(BlockId b, MemId m) {
  const auto bi = static_cast<std::size_t>(b);
  if (bi >= memo_slot_.size()) memo_slot_.resize(std::max(schedule_->pool().block_count(), bi + 1), -1);
  std::int32_t& slot = memo_slot_[bi];
  if (slot < 0) {
    slot = static_cast<std::int32_t>(memo_index_.size() / n_);
    slotted_.push_back(b);
    memo_index_.resize(memo_index_.size() + n_, -1);
  }
  std::int32_t& k = memo_index_[static_cast<std::size_t>(slot) * n_ + static_cast<std::size_t>(m)];
  const std::uint64_t hv = schedule_->holders_version(b);
  if (k >= 0) {
    Memo& e = memos_[static_cast<std::size_t>(k)];
    if (e.holders != hv) {
      e = Memo{};
      e.m = m;
      e.holders = hv;
    }
    return e;
  }
  k = static_cast<std::int32_t>(memos_.size());
  Memo& e = memos_.emplace_back();
  e.m = m;
  e.holders = hv;
  return e;
}

const FetchPathFinder::NearRoots& FetchPathFinder::near_roots(BlockId b, MemId m, const Schedule::CopyPrefix& pre, double w) {
  PrefixRoots& pr = prefix_roots_[b];
  if (pr.stamp != pre.stamp || pr.bytes != w || pr.near.size() != n_) {
    pr.stamp = pre.stamp;
    pr.bytes = w;
    pr.near.assign(n_, NearRoots{});
  }
  NearRoots& nr = pr.near[static_cast<std::size_t>(m)];
  if (nr.built) return nr;
  nr.built = true;
  const std::vector<Copy>& copies = schedule_->copies(b);
  const double* lat = rest_->latency_to(m);
  const double* inv_bw = rest_->inv_bw_to(m);
  double d[kNearRoots];
  for (std::size_t k = 0; k < pre.count; ++k) {
    const auto qi = static_cast<std::size_t>(copies[k].mem);
    if (copies[k].mem == m) continue;  // seeded at once
    double x = lat[qi] + w * inv_bw[qi];  // as through() computes its free run
    auto ki = static_cast<std::int32_t>(k);
    // Insert into the sorted near list (ties: the earlier copy first); what falls off
    // the end joins the rest.
    std::size_t at = nr.n;
    while (at > 0 && d[at - 1] > x) --at;
    if (at == kNearRoots) {
      nr.rest = std::min(nr.rest, x);
      continue;
    }
    if (nr.n == kNearRoots) {
      nr.rest = std::min(nr.rest, d[kNearRoots - 1]);
      --nr.n;
    }
    for (std::size_t j = nr.n; j > at; --j) {
      d[j] = d[j - 1];
      nr.k[j] = nr.k[j - 1];
    }
    d[at] = x;
    nr.k[at] = ki;
    ++nr.n;
  }
  return nr;
}

Time FetchPathFinder::single_holder_direct(BlockId b, MemId m, bool funnel, ChannelId* route, bool* tried) const {
  constexpr Time kOpen = std::numeric_limits<Time>::quiet_NaN();
  if (!rest_) return kOpen;
  const std::vector<Copy>& copies = schedule_->copies(b);
  if (copies.size() != 1) return kOpen;
  const MemId h = copies.front().mem;
  const ChannelId c = rest_->direct_to(m)[static_cast<std::size_t>(h)];
  if (h == m) return kOpen;
  const DataBlock& blk = schedule_->pool().block(b);
  const DeviceGraph& g = schedule_->graph();
  if (!blk.movable || g.memories[static_cast<std::size_t>(m)].capacity < blk.bytes) return kOpen;
  if (tried) *tried = true;
  if (c < 0) {
    // A destination behind one channel p -> m (a GPU behind its host memory): Eq. 3 on that
    // hop after the arrival at p, as cut_search()'s funnel computes it; its best paths are
    // those to p, extended.
    if (!funnel || g.in_channels(m).size() != 1) return kOpen;
    const ChannelId cp = g.in_channels(m)[0];
    const MemId p = g.channels[static_cast<std::size_t>(cp)].from;
    if (p == h || g.memories[static_cast<std::size_t>(p)].capacity < blk.bytes) return kOpen;
    const Time ap = single_holder_direct(b, p, false, route);
    if (ap != ap) return kOpen;
    if (route) route[1] = cp;
    return std::max(ap, schedule_->channel_finish(cp)) + g.transfer_time(cp, blk.bytes);
  }
  // The same operations as cut_search(): the root label, Eq. 3 on the hop, and the least
  // relayed last hop (relay_end_in(), every holder but h being none).
  const Time root = std::max(now_, schedule_->copy_ready(copies.front()));
  const Time direct = std::max(root, schedule_->channel_finish(c)) + g.transfer_time(c, blk.bytes);
  if (route) route[0] = c;
  const double wbytes = static_cast<double>(blk.bytes);
  // (relay_end_in() < direct, but stopping at the first relayed hop that lands earlier:
  // the whole minimum costs 1.7 % more a plan.)
  const bool relay_may_win = rest_->relay_min(*schedule_, m, wbytes, direct, direct, [&](const FetchBound::Relay& r) {
    return r.from != h && r.from_capacity >= blk.bytes;
  }) < direct;
  if (!relay_may_win) return direct;
  // A relayed path also leaves h first, by a hop h -> q (q != m, q admissible and not a
  // dead end, i.e. q leads somewhere but back to h), and its arrival is no earlier than
  // that hop's Eq. 3 label followed by the uncontended rest q -> m. When every such floor
  // is at least `direct`, so is every relayed arrival.
  const double* rest_lat = rest_->latency_to(m);
  const double* rest_inv_bw = rest_->inv_bw_to(m);
  // (Over out_hops(), whose network runs are skipped whole when even the run's floor of
  // the free run, FetchBound::network_free_run, reaches `direct`: none of its hops could
  // open the answer. Dead ends: q leads nowhere but back to h for a block this size.)
  const std::span<const Hop> hs = out_hops(h);
  for (std::size_t k = 0; k < hs.size(); ++k) {
    const Hop& hop = hs[k];
    if (hop.run >= 0) {
      const Run& run = runs_[static_cast<std::size_t>(hop.run)];
      if (!(rest_->network_free_run(m, run.group, run.span.earliest_end(*schedule_, root, wbytes), wbytes) < direct)) {
        k += run.length - 1;
        continue;
      }
    }
    const auto qi = static_cast<std::size_t>(hop.to);
    // (A dead end first: every channel out of q leads back to h or to a device too small.)
    if (hop.to == m || hop.to_capacity < blk.bytes || hop.onward_capacity < blk.bytes) continue;
    const Time start = std::max(root, schedule_->channel_finish(hop.channel));
    if (!(start + hop.latency < direct)) continue;  // T_TRANS >= T_LAT
    const Time lq = start + hop.transfer(wbytes);  // Eq. 3
    if (!(lq < direct)) continue;
    // ... and then needs the uncontended rest q -> m (through()'s free run).
    const Time free_run = FetchBound::free_run_floor(lq, rest_lat[qi] + wbytes * rest_inv_bw[qi]);
    if (free_run < direct) return kOpen;
  }
  return direct;
}

Time FetchPathFinder::direct_before_relays(BlockId b, MemId m, ChannelId& via, bool& unique) const {
  constexpr Time kOpen = std::numeric_limits<Time>::quiet_NaN();
  if (!rest_ || schedule_->copy_at(b, m)) return kOpen;
  const DataBlock& blk = schedule_->pool().block(b);
  const DeviceGraph& g = schedule_->graph();
  if (!blk.movable || g.memories[static_cast<std::size_t>(m)].capacity < blk.bytes) return kOpen;
  const ChannelId* direct = rest_->direct_to(m);
  Time best = kNever;
  int n_best = 0;
  for (const Copy& cp : schedule_->copies(b)) {
    auto consider = [&](ChannelId c) {
      const Time r = std::max(now_, schedule_->copy_ready(cp));
      const Time t = std::max(r, schedule_->channel_finish(c)) + g.transfer_time(c, blk.bytes);  // Eq. 3
      if (t < best) {
        best = t;
        via = c;
        n_best = 1;
      } else if (t == best) {
        ++n_best;
      }
    };
    if (const ChannelId d = direct[static_cast<std::size_t>(cp.mem)]; d >= 0) {
      consider(d);
    } else if (d == FetchBound::kSeveral) {
      for (ChannelId c : g.out_channels(cp.mem))
        if (g.channels[static_cast<std::size_t>(c)].to == m) consider(c);
    }
  }
  if (best == kNever) return kOpen;
  const Time relay_end = relay_end_in(m, blk.bytes, [&](MemId q) { return schedule_->copy_at(b, q) != nullptr; }, best);
  if (!(best <= relay_end)) return kOpen;
  unique = best < relay_end && n_best == 1;
  return best;
}

std::uint64_t FetchPathFinder::memo_stamp(const Memo& e) const {
  std::uint64_t v = 0;
  for (int h = 0; h < e.hops; ++h) v += channel_stamp(e.path[h]);
  return v;
}

bool FetchPathFinder::memo_exact(const Memo& e) const { return memo_stamp(e) == e.stamp; }

// The operations cut_search() and search() use (root label max(now, ready), then Eq. 3 per
// hop), so the value is bit-identical to the label this path would get.
Time FetchPathFinder::memo_path_now(const Memo& e, BlockId b) const {
  const DeviceGraph& g = schedule_->graph();
  const Bytes bytes = schedule_->pool().block(b).bytes;
  const Copy* src = schedule_->copy_at(b, g.channels[static_cast<std::size_t>(e.path[0])].from);
  if (!src) return kNever;
  Time l = std::max(now_, schedule_->copy_ready(*src));
  for (int h = 0; h < e.hops; ++h) l = std::max(l, schedule_->channel_finish(e.path[h])) + g.transfer_time(e.path[h], bytes);
  return l;
}

// Sum of the current versions of the resources on m's tree path (equal to the stamp taken
// at search time iff none of them was booked since: versions only grow).
std::uint64_t FetchPathFinder::path_stamp(const Tree& t, MemId m) const {
  const DeviceGraph& g = schedule_->graph();
  const ChannelId* via = via_of(t);
  std::uint64_t v = 0;
  for (MemId q = m; via[q] != kNone; q = g.channels[via[q]].from) v += channel_stamp(via[q]);
  return v;
}

bool FetchPathFinder::tree_valid(BlockId b, MemId m) {
  if (static_cast<std::size_t>(b) >= trees_.size()) trees_.resize(schedule_->pool().block_count());
  const Tree& t = trees_[static_cast<std::size_t>(b)];
  restrict_node_ = restricted(b) ? schedule_->graph().memories[m].node : kNone;
  return t.valid && t.holders_version == schedule_->holders_version(b) && t.node == restrict_node_ &&
         stamp_[static_cast<std::size_t>(t.slot) * n_ + static_cast<std::size_t>(m)] == path_stamp(t, m);
}

FetchPathFinder::Tree& FetchPathFinder::tree(BlockId b, MemId m) {
  const bool valid = tree_valid(b, m);  // (sizes trees_)
  Tree& t = trees_[static_cast<std::size_t>(b)];
  if (valid) {
    ++hits_;
    return t;
  }
  search(b, t, m);
  return t;
}

void FetchPathFinder::search(BlockId b, Tree& t, MemId stop) {
  ++searches_;
  const DeviceGraph& g = schedule_->graph();
  const DataBlock& blk = schedule_->pool().block(b);
  const std::size_t nm = n_;
  if (t.slot < 0) {
    t.slot = slots_++;
    tree_slotted_.push_back(b);
    if (arrival_.size() < static_cast<std::size_t>(slots_) * nm) {
      arrival_.resize(static_cast<std::size_t>(slots_) * nm);
      via_.resize(static_cast<std::size_t>(slots_) * nm);
      stamp_.resize(static_cast<std::size_t>(slots_) * nm);
    }
  }
  Time* arrival = arrival_of(t);
  ChannelId* via = via_of(t);
  std::uint64_t* stamp = stamp_of(t);
  std::fill_n(arrival, nm, kNever);
  std::fill_n(via, nm, kNone);
  std::fill_n(stamp, nm, 0);
  done_.assign(nm, 0);
  heap_.clear();
  // Virtual source S: one edge per holder, weighted by the copy's ready time.
  reset_labels();  // holder_ is all 0 after it
  t.node = restrict_node_;
  // scene_local_: a rank loads from its own node when the node holds the block, else from
  // the storage that does (a central scene database); never from another node's cache.
  bool node_has_copy = false;
  if (restrict_node_ != kNone)
    for (const Copy& c : schedule_->copies(b)) node_has_copy = node_has_copy || g.memories[c.mem].node == restrict_node_;
  for (const Copy& c : schedule_->copies(b)) {
    holder_[c.mem] = 1;
    touched_.push_back(c.mem);  // (cut_search() resets what it finds marked)
    if (restrict_node_ != kNone) {
      const bool local = g.memories[c.mem].node == restrict_node_;
      if (node_has_copy ? !local : !c.origin) continue;
    }
    const Time r = std::max(now_, schedule_->copy_ready(c));
    if (r < arrival[c.mem]) {
      arrival[c.mem] = r;
      heap_.emplace_back(r, c.mem);
      std::push_heap(heap_.begin(), heap_.end(), heap_after);
    }
  }
  const double wbytes = static_cast<double>(blk.bytes);
  if (!runs_.empty()) group_max_.assign(rest_->group_count(), kNever);
  Time lp = 0;
  // Relaxes a hop; returns q's label after it (-inf where the tree never enters q again:
  // settled, a holder, too small).
  auto relax_tree = [&](const Hop& hop) __attribute__((always_inline)) -> Time {
    const MemId q = hop.to;
    const ChannelId c = hop.channel;
    // A holder never receives a second copy (its own copy may still be in flight).
    if (done_[q] || holder_[q] || hop.to_capacity < blk.bytes) return -kNever;
    const Time lq = std::max(lp, schedule_->channel_finish(c)) + hop.transfer(wbytes);  // Eq. 3
    if (lq < arrival[q]) {
      arrival[q] = lq;
      via[q] = c;
      heap_.emplace_back(lq, q);
      std::push_heap(heap_.begin(), heap_.end(), heap_after);
      return lq;
    }
    return arrival[q];
  };
  // Early stop (a destination whose in-channels are booked far ahead, where every device
  // would be settled before it). Every label `stop` can still get comes through an
  // in-channel c = p -> stop from a device p not settled yet, whose label is at least the
  // heap's least, L: max(l_p, F(c)) + T_TRANS(c) >= max(L, F(c)) + T_TRANS(c) (the same
  // operations, monotone). A device that can get the block only from `stop` (its GPU memory,
  // its disk) gives it nothing earlier than `stop` has it. Once stop's label meets the least
  // of those floors, no relaxation lowers it and a tie never replaces it: its label and
  // incoming channel are the whole tree's. A destination behind a single channel p -> stop
  // (a GPU memory behind its host) gets its label from p's: final with p's, which is tested
  // the same way. Checked every 64 settled devices (set_early_stop()), O(in-degree) each
  // time, so searches that settle few devices (every one on the paper's cluster) never pay
  // for it.
  // A device's stamp once its path is final: its parent's plus its incoming channel's.
  auto final_stamp = [&](MemId q) {
    return via[q] == kNone ? 0 : stamp[g.channels[via[q]].from] + channel_stamp(via[q]);
  };
  // Every device not settled (but `keep`) marked so: tree_valid() never answers for it.
  auto unsettle_rest = [&](MemId keep_a, MemId keep_b) {
    for (std::size_t q = 0; q < nm; ++q)
      if (!done_[q] && static_cast<MemId>(q) != keep_a && static_cast<MemId>(q) != keep_b) stamp[q] = kUnsettled;
  };
  std::size_t settled = 0, next_check = early_stop_;
  auto only_from = [&](MemId p, MemId q) {
    for (ChannelId c : g.in_channels(p))
      if (g.channels[static_cast<std::size_t>(c)].from != q) return false;
    return true;
  };
  auto is_final = [&](MemId q, Time L) {
    const Time x = arrival[q];
    if (!(x < kNever)) return false;
    for (ChannelId c : g.in_channels(q)) {
      const MemId p = g.channels[static_cast<std::size_t>(c)].from;
      if (done_[p] || (!holder_[p] && only_from(p, q))) continue;
      if (std::max(L, schedule_->channel_finish(c)) + g.transfer_time(c, blk.bytes) < x) return false;
    }
    return true;
  };
  // True when stop's label and path are final; then they are set, with their stamps.
  auto stop_early = [&](Time L, MemId& final_host) {
    if (is_final(stop, L)) {
      stamp[stop] = final_stamp(stop);
      return true;
    }
    const std::vector<ChannelId>& in = g.in_channels(stop);
    if (holder_[stop] || in.size() != 1 || g.memories[static_cast<std::size_t>(stop)].capacity < blk.bytes) return false;
    const ChannelId c = in[0];
    const MemId p = g.channels[static_cast<std::size_t>(c)].from;
    if (done_[p] || holder_[p] || g.memories[static_cast<std::size_t>(p)].capacity < blk.bytes || !is_final(p, L))
      return false;
    stamp[p] = final_stamp(p);
    final_host = p;
    arrival[stop] = std::max(arrival[p], schedule_->channel_finish(c)) + g.transfer_time(c, blk.bytes);  // Eq. 3
    via[stop] = c;
    stamp[stop] = stamp[p] + channel_stamp(c);
    return true;
  };
  if (blk.movable) {
    while (!heap_.empty()) {
      std::pop_heap(heap_.begin(), heap_.end(), heap_after);
      const MemId p = heap_.back().second;
      lp = heap_.back().first;
      heap_.pop_back();
      if (done_[p]) continue;
      done_[p] = 1;
      // p's tree path is final now, and its parent's stamp was taken before.
      stamp[p] = final_stamp(p);
      if (p == stop) {
        // The asked destination is final (so is every device settled before it, the path
        // to it included): stop. The others are left unsettled, their stamps set to a
        // value no path's sum of versions takes, so tree_valid() never answers for them.
        unsettle_rest(kNone, kNone);
        break;
      }
      const std::span<const Hop> hs = out_hops(p);
      for (std::size_t h = 0; h < hs.size(); ++h) {
        // A network run (build_runs()) none of whose hops can lower its member's label does
        // nothing: every l_q >= the run's Eq. 3 floor >= the largest label of the group's
        // members when last looked at (labels only fall), so it is skipped, exactly.
        if (hs[h].run >= 0) {
          const Run& run = runs_[static_cast<std::size_t>(hs[h].run)];
          Time& group_max = group_max_[static_cast<std::size_t>(run.group)];
          if (run.span.earliest_end(*schedule_, lp, wbytes) >= group_max) {
            h += run.length - 1;
            continue;
          }
          Time run_max = -kNever;  // (settled members, p among them, are never relaxed again)
          for (std::size_t e = h + run.length; h < e; ++h) run_max = std::max(run_max, relax_tree(hs[h]));
          group_max = run_max;
          --h;
          continue;
        }
        relax_tree(hs[h]);
      }
      // (After p's relaxations: every settled device has given stop what it can.)
      if (early_stop_ > 0 && stop != kNone && ++settled >= next_check) {
        next_check += early_stop_;
        MemId final_host = kNone;
        if (stop_early(lp, final_host)) {
          unsettle_rest(stop, final_host);
          ++early_stops_;
          break;
        }
      }
    }
  }
  if (!t.valid) valid_trees_.push_back(b);
  t.valid = true;
  t.holders_version = schedule_->holders_version(b);
}

Time FetchPathFinder::arrival(BlockId b, MemId m) {
  const Tree& t = tree(b, m);
  return arrival_.data()[static_cast<std::size_t>(t.slot) * n_ + static_cast<std::size_t>(m)];
}

int FetchPathFinder::via_hops(MemId m, MemId* root) const {
  const DeviceGraph& g = schedule_->graph();
  int h = 0;
  MemId q = m;
  while (label_via_[static_cast<std::size_t>(q)] != kNone) {
    if (++h > kMemoHops) return kMemoHops + 1;
    q = g.channels[static_cast<std::size_t>(label_via_[static_cast<std::size_t>(q)])].from;
  }
  if (root) *root = holder_[static_cast<std::size_t>(q)] ? q : kNone;
  return h;
}

void FetchPathFinder::path(BlockId b, MemId m, std::vector<ChannelId>& out) {
  out.clear();
  if (rest_ && !restricted(b)) {
    // (A restricted block's paths are the tree's alone.)
    // The best path when it is the only one (no tie anywhere along it): every search,
    // whatever its order, finds exactly this one.
    // Its arrival first (memoised, or a search cut at the best label found), so that the
    // search for ties can drop every label that cannot end at it.
    // A ray queue whose direct hop (or, to a GPU, the hop to its host) lands no later than
    // any other path: that hop is also the tree's path. The tree grows from the one holder,
    // whose channels are relaxed first, and a label is replaced only by a smaller one, so a
    // path that ties with the direct hop never replaces it (nor, to a GPU behind p, the hop
    // to p, which m's path extends).
    ChannelId route[2] = {kNone, kNone};
    if (const Time a = single_holder_direct(b, m, true, route); a == a) {
      out.assign(route, route + (route[1] == kNone ? 1 : 2));
      return;
    }
    const Time best = arrival_within(b, m, -kNever, [](Time) { return false; });
    if (best == kNever) return;
    bool relayed = false;
    {
      const Memo& e = memo(b, m);
      if (e.hops >= 0 && e.unique && memo_exact(e)) {  // proved the only best path when found
        ++hits_;
        out.assign(e.path, e.path + e.hops);
        return;
      }
      relayed = e.hops >= 2 && memo_exact(e);
    }
    // A best path through a relay usually ties with others (interchangeable relays give
    // equal Eq. 3 labels), and then only the tree answers: go there directly (the same
    // path either way, see above; on the bench instance nine in ten such searches tie).
    if (!relayed) {
      Time dropped = kNever;
      const auto beyond = [best](Time x) { return x > best; };
      const Time a = cut_search<decltype(beyond), true>(b, m, -kNever, beyond, dropped);
      if (a == kNever) return;
      const DeviceGraph& g = schedule_->graph();
      bool unique = true;
      MemId q = m;
      for (std::size_t k = 0; unique && label_via_[static_cast<std::size_t>(q)] != kNone; ++k) {
        if (k > n_ || tie_[static_cast<std::size_t>(q)]) unique = false;
        out.push_back(label_via_[static_cast<std::size_t>(q)]);
        q = g.channels[static_cast<std::size_t>(label_via_[static_cast<std::size_t>(q)])].from;
      }
      if (unique && holder_[static_cast<std::size_t>(q)] && !tie_[static_cast<std::size_t>(q)]) {
        ++cut_searches_;
        std::reverse(out.begin(), out.end());
        return;
      }
      out.clear();
    }
  }
  const Tree& t = tree(b, m);
  if (arrival_of(t)[m] == kNever) return;
  const DeviceGraph& g = schedule_->graph();
  const ChannelId* via = via_of(t);
  for (MemId q = m; via[q] != kNone; q = g.channels[via[q]].from) out.push_back(via[q]);
  std::reverse(out.begin(), out.end());
}

}  // namespace rayline
