#include "sched/timeline/schedule.hpp"

#include <bit>

#include <algorithm>
#include <array>
#include <iterator>
#include <span>
#include <stdexcept>

namespace rayline {

namespace {
// reproject(): dependency lists longer than this are read through OpenDeps.
constexpr std::uint32_t kFewDeps = 16;
}  // namespace

// A device's leaving entries are in serial order: the first with a serial >= `serial`.
template <class List>
auto Schedule::first_leaving(List& lv, std::uint64_t serial) {
  return std::lower_bound(lv.begin(), lv.end(), serial, [](const Leaving& l, std::uint64_t x) { return l.serial < x; });
}

Schedule::Schedule(const DeviceGraph& graph, const JobPool& pool)
    : graph_(&graph),
      pool_(&pool),
      device_tl_(graph.computes.size()),
      resource_tl_(graph.resources.size()),
      channel_finish_(graph.channels.size(), 0.0),
      resource_version_(graph.resources.size(), 0),
      node_epoch_(graph.nodes.size(), 0),
      used_(graph.memories.size(), 0),
      device_pending_(graph.computes.size(), 0) {
  std::vector<std::int32_t> fanout(graph.resources.size(), 0);
  for (const Channel& c : graph.channels)
    for (ResourceId r : c.resources) ++fanout[static_cast<std::size_t>(r)];
  for (std::size_t c = 0; c < graph.channels.size(); ++c) {
    const std::vector<ResourceId>& rs = graph.channels[c].resources;
    if (rs.empty() || rs.size() > kRouteMax) continue;
    for (ResourceId r : rs)
      if (fanout[static_cast<std::size_t>(r)] > kKeptFanout) {
        if (on_demand_.empty()) {
          on_demand_.assign(graph.channels.size(), 0);
          on_demand_route_.resize(graph.channels.size());
        }
        on_demand_[c] = 1;
        std::array<ResourceId, kRouteMax>& route = on_demand_route_[c];
        route.fill(rs.front());
        std::copy(rs.begin(), rs.end(), route.begin());
        break;
      }
  }
  auto kept = [&](std::size_t c) { return on_demand_.empty() || !on_demand_[c]; };
  resource_channels_first_.assign(graph.resources.size() + 1, 0);
  for (std::size_t c = 0; c < graph.channels.size(); ++c)
    if (kept(c))
      for (ResourceId r : graph.channels[c].resources) ++resource_channels_first_[static_cast<std::size_t>(r) + 1];
  for (std::size_t r = 0; r < graph.resources.size(); ++r) resource_channels_first_[r + 1] += resource_channels_first_[r];
  resource_channels_.resize(static_cast<std::size_t>(resource_channels_first_.back()));
  std::vector<std::int32_t> fill(resource_channels_first_.begin(), resource_channels_first_.end() - 1);
  for (std::size_t c = 0; c < graph.channels.size(); ++c)
    if (kept(c))
      for (ResourceId r : graph.channels[c].resources) resource_channels_[static_cast<std::size_t>(fill[static_cast<std::size_t>(r)]++)] = static_cast<ChannelId>(c);
}

// Same arithmetic as before the cache: max(0, busy_until of each resource in order).
void Schedule::resource_busy_changed(ResourceId r) {
  const auto first = static_cast<std::size_t>(resource_channels_first_[static_cast<std::size_t>(r)]);
  const auto last = static_cast<std::size_t>(resource_channels_first_[static_cast<std::size_t>(r) + 1]);
  for (std::size_t k = first; k < last; ++k) {
    const ChannelId c = resource_channels_[k];
    Time t = 0;
    for (ResourceId q : graph_->channels[c].resources) t = std::max(t, resource_tl_[q].busy_until);
    channel_finish_[static_cast<std::size_t>(c)] = t;
  }
}

void Schedule::resource_busy_raised(ResourceId r, Time t) {
  const auto first = static_cast<std::size_t>(resource_channels_first_[static_cast<std::size_t>(r)]);
  const auto last = static_cast<std::size_t>(resource_channels_first_[static_cast<std::size_t>(r) + 1]);
  for (std::size_t k = first; k < last; ++k) {
    Time& f = channel_finish_[static_cast<std::size_t>(resource_channels_[k])];
    f = std::max(f, t);
  }
}

void Schedule::touch(const Activity& a) {
  if (a.kind == ActivityKind::Exec) {
    touch_node(graph_->computes[a.device].node);
    return;
  }
  const Channel& ch = graph_->channels[a.channel];
  touch_memory(ch.from);
  touch_memory(ch.to);
}

Copy* Schedule::mutable_copy(BlockId b, MemId m) {
  return const_cast<Copy*>(static_cast<const Schedule*>(this)->copy_at(b, m));
}

void Schedule::add_copy(BlockId b, Copy c) {
  if (static_cast<std::size_t>(b) >= copies_.size()) {
    copies_.resize(pool_->block_count());
    holders_version_.resize(pool_->block_count(), 0);
    holder_mask_.resize(pool_->block_count(), 0);
  }
  if (copy_at(b, c.mem)) throw std::logic_error("block already on that memory device: " + pool_->block(b).name);
  used_[c.mem] += pool_->block(b).bytes;
  touch_memory(c.mem);
  ++holders_version_[b];
  if (static_cast<std::uint32_t>(c.mem) < 64u) holder_mask_[static_cast<std::size_t>(b)] |= std::uint64_t{1} << c.mem;
  note_cached(b, c.mem);
  copies_[b].push_back(std::move(c));
}

Schedule::CopyIndex& Schedule::copy_index(BlockId b) const {
  CopyIndex& ix = copy_index_[b];
  const std::vector<Copy>& cs = copies_[static_cast<std::size_t>(b)];
  if (ix.holders != holders_version_[static_cast<std::size_t>(b)]) {
    ix.pos.assign(graph_->memories.size(), -1);
    for (std::size_t k = 0; k < cs.size(); ++k) ix.pos[static_cast<std::size_t>(cs[k].mem)] = static_cast<std::int32_t>(k);
    ix.holders = holders_version_[static_cast<std::size_t>(b)];
    // The leading initial copies and an FNV-1a stamp of what they are.
    std::uint64_t h = 1469598103934665603ull;
    std::size_t n = 0;
    for (; n < cs.size() && cs[n].producer == kNone && cs[n].initial_ready == cs[0].initial_ready; ++n) {
      h = (h ^ static_cast<std::uint64_t>(cs[n].mem)) * 1099511628211ull;
      h = (h ^ std::bit_cast<std::uint64_t>(cs[n].initial_ready)) * 1099511628211ull;
    }
    ix.prefix = {n, (h ^ n) * 1099511628211ull};
  }
  return ix;
}

const Copy* Schedule::indexed_copy_at(BlockId b, MemId m) const {
  const CopyIndex& ix = copy_index(b);
  const std::int32_t k = ix.pos[static_cast<std::size_t>(m)];
  return k >= 0 ? &copies_[static_cast<std::size_t>(b)][static_cast<std::size_t>(k)] : nullptr;
}

const std::int32_t* Schedule::copy_positions(BlockId b) const {
  if (static_cast<std::size_t>(b) >= copies_.size() || copies_[static_cast<std::size_t>(b)].size() <= kScannedCopies) return nullptr;
  return copy_index(b).pos.data();
}

Schedule::CopyPrefix Schedule::initial_prefix(BlockId b) const {
  if (static_cast<std::size_t>(b) >= copies_.size() || copies_[static_cast<std::size_t>(b)].size() <= kScannedCopies) return {};
  return copy_index(b).prefix;
}

void Schedule::note_cached(BlockId b, MemId m) {
  const DataBlock& blk = pool_->block(b);
  if (blk.consumed || !blk.movable) return;
  if (cache_candidates_.size() < graph_->memories.size()) cache_candidates_.resize(graph_->memories.size());
  auto& v = cache_candidates_[static_cast<std::size_t>(m)];
  const auto it = std::lower_bound(v.begin(), v.end(), b);
  if (it == v.end() || *it != b) v.insert(it, b);
}

void Schedule::put_initial(BlockId b, MemId m, Time ready, bool origin) {
  Copy c;
  c.mem = m;
  c.initial_ready = ready;
  c.origin = origin;
  add_copy(b, std::move(c));
}

// admission()'s order of device m's live leaving entries (schedule.hpp, LeavingOrder):
// sorted afresh once an activity's end may have moved, else the entries made since are
// merged in. Any other change to an entry (taken bytes, its activities ending) is read
// from the entry where admission() meets it.
Schedule::LeavingOrder& Schedule::leaving_order(MemId m) const {
  if (leaving_order_.size() < leaving_.size()) leaving_order_.resize(leaving_.size());
  LeavingOrder& o = leaving_order_[static_cast<std::size_t>(m)];
  const std::vector<Leaving>& lv = leaving_[static_cast<std::size_t>(m)];
  if (o.epoch != ends_epoch_ || !kept_leaving_order_) {
    o.epoch = ends_epoch_;
    o.head = 0;
    o.sorted.clear();
    o.recent.clear();
    for (const Leaving& l : lv)
      if (!l.after.empty()) o.sorted.push_back({leaving_at(l), l.block, l.serial});
    std::sort(o.sorted.begin(), o.sorted.end());
    o.next_serial = next_leaving_serial_;
    return o;
  }
  if (o.next_serial == next_leaving_serial_) return o;
  const auto first = first_leaving(lv, o.next_serial);
  const std::size_t had = o.recent.size();
  for (auto it = first; it != lv.end(); ++it)
    if (!it->after.empty()) o.recent.push_back({leaving_at(*it), it->block, it->serial});
  std::sort(o.recent.begin() + static_cast<std::ptrdiff_t>(had), o.recent.end());
  std::inplace_merge(o.recent.begin(), o.recent.begin() + static_cast<std::ptrdiff_t>(had), o.recent.end());
  if (o.recent.size() > 64 && o.recent.size() * 8 > o.sorted.size() - o.head) {
    o.sorted.erase(o.sorted.begin(), o.sorted.begin() + static_cast<std::ptrdiff_t>(o.head));
    o.head = 0;
    const std::size_t n = o.sorted.size();
    o.sorted.insert(o.sorted.end(), o.recent.begin(), o.recent.end());
    std::inplace_merge(o.sorted.begin(), o.sorted.begin() + static_cast<std::ptrdiff_t>(n), o.sorted.end());
    o.recent.clear();
  }
  o.next_serial = next_leaving_serial_;
  return o;
}

// Capacity: eviction is a decision the plan makes and can explain. Candidates,
// cheapest first:
//   1. bytes already leaving m at a planned time (a consumed ray queue, a queue moved on);
//   2. cached copies nobody queued wants any more (next use = never: Belady's first pick);
//   3. cached copies wanted by fewer queued jobs.
// Within a class the copy whose last planned use ends first goes first (it frees soonest).
// Candidates are taken in that order until the room suffices; then any taken one the rest
// make unnecessary is given back, latest first (a leaving entry that
// frees late, taken before a victim that alone suffices, only delayed the data, and a
// small victim taken before a large one was evicted for nothing).
// Room is handed over only as far as needed: what a leaving entry or the last victim frees
// beyond the need stays reserved until the activities that free it end, and whoever counts
// on it later waits for them too (before, it was free at once, so a later fetch could
// start while the evicted copy was still in use: over capacity once reality ran late).
// Never evicted: a block's origin copy, ray queues (unique data), the job's own inputs.
Schedule::Admission Schedule::admission(MemId m, Bytes bytes, const std::vector<BlockId>& keep) const {
  Admission adm;
  const Bytes cap = graph_->memories[m].capacity;
  if (bytes > cap) {
    adm.at = kNever;
    return adm;
  }
  // Nothing to place: nothing to evict (even on an overfull device).
  if (bytes == 0) return adm;
  // used_ may exceed the capacity: data put in place by a workload (new ray queues) is
  // not admitted; the difference must then be freed first (signed arithmetic).
  if (used_[m] <= cap && cap - used_[m] >= bytes) return adm;
  constexpr std::uint32_t kCopy = ~std::uint32_t{0};
  struct Cand { int value; Time at; Bytes bytes; BlockId block; std::uint32_t leaving; };
  std::vector<Cand> cands;
  const auto free0 = static_cast<std::int64_t>(cap) - static_cast<std::int64_t>(used_[m]);
  const auto want = static_cast<std::int64_t>(bytes);
  std::vector<std::uint32_t> chosen;
  std::int64_t free = free0;
  // Leaving bytes come first under either eviction policy (they free without evicting
  // anything), by (at, block, then the order they were made): taken from the kept order
  // until the room suffices. Cached copies follow, in the policy's order below.
  if (static_cast<std::size_t>(m) < leaving_.size()) {
    const std::vector<Leaving>& lv = leaving_[static_cast<std::size_t>(m)];
    LeavingOrder& order = leaving_order(m);
    // An entry gone (taken whole, or compacted away once its activities ended) or dead
    // stays so: its key is dropped where it is met, so later admissions do not meet it.
    auto take = [&](const LeavingKey& k) {
      const auto it = first_leaving(lv, k.serial);
      if (it == lv.end() || it->serial != k.serial || it->after.empty()) return false;
      chosen.push_back(static_cast<std::uint32_t>(cands.size()));
      cands.push_back({-1, k.at, it->bytes, it->block, static_cast<std::uint32_t>(it - lv.begin())});
      free += static_cast<std::int64_t>(it->bytes);
      return true;
    };
    std::vector<LeavingKey>& sorted = order.sorted;
    std::vector<LeavingKey>& recent = order.recent;
    std::size_t a = order.head, r = 0, sorted_kept = 0, recent_kept = 0;
    while (free < want && (a < sorted.size() || r < recent.size())) {
      if (r == recent.size() || (a < sorted.size() && sorted[a] < recent[r])) {
        if (take(sorted[a])) sorted[order.head + sorted_kept++] = sorted[a];
        ++a;
      } else {
        if (take(recent[r])) recent[recent_kept++] = recent[r];
        ++r;
      }
    }
    // The live keys walked, moved up against the rest (the order is kept).
    std::move_backward(sorted.begin() + static_cast<std::ptrdiff_t>(order.head),
                       sorted.begin() + static_cast<std::ptrdiff_t>(order.head + sorted_kept),
                       sorted.begin() + static_cast<std::ptrdiff_t>(a));
    order.head = a - sorted_kept;
    recent.erase(recent.begin() + static_cast<std::ptrdiff_t>(recent_kept), recent.begin() + static_cast<std::ptrdiff_t>(r));
  }
  const std::size_t leaving_chosen = chosen.size();
  std::vector<BlockId>* cached = static_cast<std::size_t>(m) < cache_candidates_.size() ? &cache_candidates_[static_cast<std::size_t>(m)] : nullptr;
  std::size_t kept = 0;
  for (std::size_t i = 0; free < want && cached && i < cached->size(); ++i) {
    const auto b = static_cast<std::size_t>((*cached)[i]);
    if (!copy_at(static_cast<BlockId>(b), m)) continue;  // gone: dropped from the list
    (*cached)[kept++] = static_cast<BlockId>(b);
    const DataBlock& blk = pool_->block(static_cast<BlockId>(b));
    if (std::find(keep.begin(), keep.end(), static_cast<BlockId>(b)) != keep.end()) continue;
    for (const Copy& c : copies_[b]) {
      if (c.mem != m || c.origin) continue;
      // The last copy of a block the queue still wants is data, not cache.
      if (copies_[b].size() == 1 && pool_->queued_demand(static_cast<BlockId>(b)) > 0) continue;
      Time at = copy_ready(c);
      for (ActivityId u : c.users) at = std::max(at, end_of(u));
      cands.push_back({pool_->queued_demand(static_cast<BlockId>(b)), at, blk.bytes, static_cast<BlockId>(b), kCopy});
    }
  }
  if (cached && free < want) cached->resize(kept);
  const bool lru = eviction_policy_ == EvictionPolicy::Lru;
  // The cached copies' order (ties, rare, by the order they were listed in): only its first
  // candidates are needed, so they are drawn from a heap rather than sorting all of them
  // (a full device under a long plan lists thousands).
  const auto first = [&](std::uint32_t x, std::uint32_t y) {
    const Cand& a = cands[x];
    const Cand& b = cands[y];
    if (!lru && a.value != b.value) return a.value < b.value;
    if (a.at != b.at) return a.at < b.at;
    if (a.block != b.block) return a.block < b.block;
    return x < y;
  };
  const auto later = [&](std::uint32_t x, std::uint32_t y) { return first(y, x); };
  // Candidates in that order until the room suffices, then those no longer needed dropped,
  // the one that frees last first: a late leaving entry taken before a victim that alone
  // suffices would only delay the incoming data. (The leaving entries taken above are
  // the first ones; cached copies follow.)
  std::vector<std::uint32_t> heap;
  if (free < want)
    for (std::uint32_t i = static_cast<std::uint32_t>(leaving_chosen); i < cands.size(); ++i) heap.push_back(i);
  std::make_heap(heap.begin(), heap.end(), later);
  for (auto end = heap.end(); end != heap.begin() && free < want; --end) {
    std::pop_heap(heap.begin(), end, later);
    const std::uint32_t i = *(end - 1);
    free += static_cast<std::int64_t>(cands[i].bytes);
    chosen.push_back(i);
  }
  if (free < want) {
    adm.at = kNever;
    return adm;
  }
  if (chosen.size() > 1) {
    std::vector<std::uint32_t> by_late(chosen);
    std::stable_sort(by_late.begin(), by_late.end(), [&](std::uint32_t a, std::uint32_t b) { return cands[a].at > cands[b].at; });
    std::vector<char> dropped(cands.size(), 0);
    for (std::uint32_t i : by_late)
      if (free - static_cast<std::int64_t>(cands[i].bytes) >= want) {
        free -= static_cast<std::int64_t>(cands[i].bytes);
        dropped[i] = 1;
      }
    std::erase_if(chosen, [&](std::uint32_t i) { return dropped[i] != 0; });  // one pass, order kept
  }
  // Every candidate left is needed, so only the last one can free more than the need.
  free = free0;
  for (std::uint32_t i : chosen) {
    const Cand& c = cands[i];
    const std::int64_t need = want - free;
    free += static_cast<std::int64_t>(c.bytes);
    adm.at = std::max(adm.at, c.at);
    if (c.leaving != kCopy) {
      // Only the bytes needed change hands; the rest of the entry stays reserved until its
      // activities end, so no later admission counts on it without waiting for them too.
      const Leaving& l = leaving_[static_cast<std::size_t>(m)][c.leaving];
      adm.wait_for.insert(adm.wait_for.end(), l.after.begin(), l.after.end());
      adm.taken.push_back({c.leaving, c.block, static_cast<Bytes>(std::min<std::int64_t>(need, static_cast<std::int64_t>(c.bytes)))});
    } else {
      adm.victims.emplace_back(c.block, m);
      adm.victim_at.push_back(c.at);
      const Copy* cp = copy_at(c.block, m);
      if (cp->producer != kNone) adm.wait_for.push_back(cp->producer);
      adm.wait_for.insert(adm.wait_for.end(), cp->users.begin(), cp->users.end());
      if (free > want) adm.victim_surplus = static_cast<Bytes>(free - want);
    }
  }
  return adm;
}

void Schedule::evict(BlockId b, MemId m, Time at, ActivityId for_activity, const std::string& reason) {
  auto& v = copies_[b];
  auto it = std::find_if(v.begin(), v.end(), [m](const Copy& c) { return c.mem == m; });
  if (it == v.end()) throw std::logic_error("evicting a copy that is not there");
  std::vector<ActivityId> after(it->users.begin(), it->users.end());
  if (it->producer != kNone) {
    after.push_back(it->producer);
    if (!it->users.empty()) evicted_readers_[it->producer].append(it->users.begin(), it->users.end());
  }
  used_[m] -= pool_->block(b).bytes;
  touch_memory(m);
  v.erase(it);
  ++holders_version_[b];
  forget_holder(b, m);
  evictions_.push_back({b, m, at, for_activity, pool_->queued_demand(b), reason, std::move(after)});
}

// Belady-style explanation: the victim had no (or the least) queued demand, i.e. its next
// use is the farthest we know of; its last planned use ends by `adm.at`.
template <class What>
void Schedule::apply_evictions(const Admission& adm, MemId m, ActivityId for_activity, const What& what) {
  for (std::size_t i = 0; i < adm.victims.size(); ++i) {
    const auto [vb, vm] = adm.victims[i];
    const Time at = i < adm.victim_at.size() ? adm.victim_at[i] : adm.at;
    evict(vb, vm, at, for_activity,
          "room for " + what() + "; victim wanted by " + std::to_string(pool_->queued_demand(vb)) +
              " queued job(s), last planned use ends by t=" + std::to_string(at) + " s");
  }
  // Leaving bytes the incoming data counts on: handed over (their room now belongs to it,
  // from `adm.at` on, and the activity waits for the ones that free it).
  bool emptied = false;
  for (const Admission::Taken& t : adm.taken) {
    Leaving& l = leaving_[static_cast<std::size_t>(m)][t.leaving];
    if (l.mem != m || l.block != t.block || l.bytes < t.bytes)
      throw std::logic_error("an admission applied to a schedule that changed since it was made");
    l.bytes -= t.bytes;
    used_[m] -= t.bytes;
    emptied = emptied || l.bytes == 0;
  }
  if (emptied) {  // (dead entries have no bytes either: they go too)
    std::erase_if(leaving_[static_cast<std::size_t>(m)], [](const Leaving& l) { return l.bytes == 0; });
    dead_leaving_[static_cast<std::size_t>(m)] = 0;
  }
  // The last victim's room beyond the need is free only once its producer and users end.
  if (adm.victim_surplus > 0 && !adm.victims.empty()) {
    const Eviction& e = evictions_.back();
    std::vector<ActivityId> after;
    for (ActivityId a : e.after)
      if (acts_[a].state != ActivityState::Done && acts_[a].state != ActivityState::Failed) after.push_back(a);
    if (!after.empty()) {
      used_[e.mem] += adm.victim_surplus;
      Leaving& added = add_leaving({e.block, e.mem, {}, adm.victim_surplus});
      for (ActivityId a : after) wait_for_end(added, a);
    }
  }
}

Time Schedule::leaving_at(const Leaving& l) const {
  Time t = 0;
  for (ActivityId a : l.after) t = std::max(t, end_of(a));
  return t;
}

void Schedule::drop_copy_later(BlockId b, MemId m, ActivityId leaving_with) {
  auto& v = copies_[b];
  auto it = std::find_if(v.begin(), v.end(), [m](const Copy& c) { return c.mem == m; });
  if (it == v.end()) throw std::logic_error("dropping a copy that is not there");
  const ActivityId producer = it->producer;
  const Time ready = it->initial_ready;
  v.erase(it);
  ++holders_version_[b];
  forget_holder(b, m);
  wait_for_end(add_leaving({b, m, {}, pool_->block(b).bytes, leaving_with, producer, ready}), leaving_with);
}


ActivityId Schedule::commit_transfer(BlockId b, ChannelId c, JobId for_job, Time not_before, const Admission& adm) {
  const Channel& ch = graph_->channels[c];
  const Copy* src = copy_at(b, ch.from);
  if (!src) throw std::logic_error("transfer source holds no copy of " + pool_->block(b).name);
  if (copy_at(b, ch.to)) throw std::logic_error("transfer destination already holds " + pool_->block(b).name);
  if (adm.at == kNever) throw std::logic_error("transfer committed without room at the destination");
  const DataBlock& blk = pool_->block(b);
  const auto id = static_cast<ActivityId>(acts_.size());
  Activity a;
  a.kind = ActivityKind::Transfer;
  a.job = for_job;
  a.block = b;
  a.channel = c;
  a.bytes = blk.bytes;
  a.move = blk.consumed;  // Sec. 5.1: ray queues move (and merge on arrival), scene data is copied
  a.duration = graph_->transfer_time(c, blk.bytes);  // Eq. 1
  // Eq. 3: the hop starts when the data is at the source and the channel is free.
  const Time start = std::max({not_before, copy_ready(*src), channel_finish(c), adm.at});
  a.start = a.planned_start = start;
  a.end = a.planned_end = start + a.duration;
  // Sizes known up front: at most one allocation, and none for a short list.
  a.deps.reserve((src->producer != kNone ? 1 : 0) + adm.wait_for.size());
  std::size_t prev = 0;
  for (ResourceId r : ch.resources) prev += resource_tl_[r].items.empty() ? 0 : 1;
  a.timeline_prev.reserve(prev);
  if (src->producer != kNone) a.deps.push_back(src->producer);
  a.deps.append(adm.wait_for.begin(), adm.wait_for.end());
  for (ResourceId r : ch.resources) {
    Timeline& tl = resource_tl_[r];
    if (!tl.items.empty()) a.timeline_prev.push_back(tl.items.back());
    tl.items.push_back(id);
    tl.busy_until = a.end;
    ++resource_version_[r];
  }
  // (start >= FinishTime(c) >= every busy_until on c, so each was raised to a.end.)
  for (ResourceId r : ch.resources) resource_busy_raised(r, a.end);
  touch(a);
  acts_.push_back(std::move(a));
  pending_.push_back(id);
  ++unfinished_;
  if (for_job >= 0) {
    if (static_cast<std::size_t>(for_job) >= job_transfers_.size()) job_transfers_.resize(static_cast<std::size_t>(for_job) + 1);
    job_transfers_[static_cast<std::size_t>(for_job)].push_back(id);
  }
  apply_evictions(adm, ch.to, id, [&] { return blk.name + " (" + std::to_string(blk.bytes) + " B)"; });
  if (blk.consumed) {
    drop_copy_later(b, ch.from, id);
  } else {
    mutable_copy(b, ch.from)->users.push_back(id);
  }
  Copy dst;
  dst.mem = ch.to;
  dst.producer = id;
  add_copy(b, std::move(dst));
  return id;
}

ActivityId Schedule::commit_exec(JobId j, DeviceId d, Time not_before, const Admission& out_adm) {
  const Job& job = pool_->job(j);
  const MemId m = graph_->computes[d].memory;
  if (out_adm.at == kNever) throw std::logic_error("E-job committed without room for its outputs");
  const auto id = static_cast<ActivityId>(acts_.size());
  Activity a;
  a.kind = ActivityKind::Exec;
  a.job = j;
  a.device = d;
  // Eq. 2's input sizes (on the stack for the usual few inputs).
  std::array<InputSize, 8> few;
  std::vector<InputSize> many;
  std::size_t n_sizes = 0;
  Time ready = 0;
  a.deps.reserve(job.inputs.size() + job.after.size() + out_adm.wait_for.size());  // (at most that many)
  for (BlockId b : job.inputs) {
    const Copy* c = copy_at(b, m);
    if (!c) throw std::logic_error("E-job committed before input " + pool_->block(b).name + " is on its memory");
    ready = std::max(ready, copy_ready(*c));
    if (c->producer != kNone) a.deps.push_back(c->producer);
    const InputSize sz{pool_->block(b).kind, pool_->block(b).bytes};
    if (n_sizes < few.size()) {
      few[n_sizes] = sz;
    } else {
      if (many.empty()) many.assign(few.begin(), few.end());
      many.push_back(sz);
    }
    ++n_sizes;
  }
  for (JobId p : job.after) {
    const ActivityId pa = pool_->activity(p);
    if (pa == kNone) throw std::logic_error("E-job committed before a job it must follow");
    a.deps.push_back(pa);
    ready = std::max(ready, acts_[pa].end);
  }
  a.deps.append(out_adm.wait_for.begin(), out_adm.wait_for.end());
  ready = std::max(ready, out_adm.at);
  a.data_ready = ready;
  const std::span<const InputSize> sizes = n_sizes <= few.size() ? std::span<const InputSize>(few.data(), n_sizes)
                                                                  : std::span<const InputSize>(many);
  a.duration = graph_->timing.exec_time(d, job.type, sizes);  // Eq. 2
  a.setup = a.duration > 0 ? graph_->timing.setup_time(d, job.type) : 0;
  Timeline& tl = device_tl_[d];
  const Time start = std::max({not_before, tl.busy_until, ready});
  a.start = a.planned_start = start;
  a.end = a.planned_end = start + a.duration;
  if (!tl.items.empty()) a.timeline_prev.push_back(tl.items.back());
  tl.items.push_back(id);
  tl.busy_until = a.end;
  touch(a);
  acts_.push_back(std::move(a));
  pending_.push_back(id);
  ++unfinished_;
  ++device_pending_[d];
  apply_evictions(out_adm, m, id, [&] { return "outputs of " + job.name; });
  for (BlockId b : job.inputs) {
    if (pool_->block(b).consumed) drop_copy_later(b, m, id);
    else mutable_copy(b, m)->users.push_back(id);
  }
  for (BlockId o : job.outputs) {
    Copy c;
    c.mem = m;
    c.producer = id;
    add_copy(o, std::move(c));
  }
  return id;
}

const ActivityList& Schedule::transfers_for(JobId j) const {
  static const ActivityList kNoTransfers;
  return j >= 0 && static_cast<std::size_t>(j) < job_transfers_.size() ? job_transfers_[static_cast<std::size_t>(j)]
                                                                         : kNoTransfers;
}

void Schedule::forget_user(Copy* c, ActivityId a) {
  if (c) c->users.erase(a);
}

// The copy of b on m that `producer` makes leaves the plan now; its bytes stay reserved
// until `producer` ends (a Leaving entry), so no later admission counts on room that the
// producer's own evictions free only once their users are done. A copy evicted since
// (or replaced by another producer's) is left alone. False: a live activity still uses it.
bool Schedule::withdraw_copy(BlockId b, MemId m, ActivityId producer) {
  auto& v = copies_[b];
  auto it = std::find_if(v.begin(), v.end(), [&](const Copy& c) { return c.mem == m && c.producer == producer; });
  if (it == v.end()) return true;
  if (!it->users.empty()) return false;
  v.erase(it);
  ++holders_version_[b];
  forget_holder(b, m);
  wait_for_end(add_leaving({b, m, {}, pool_->block(b).bytes}), producer);
  return true;
}

bool Schedule::read_after_eviction(ActivityId producer) const {
  const auto it = evicted_readers_.find(producer);
  if (it == evicted_readers_.end()) return false;
  for (ActivityId u : it->second)
    if (!acts_[u].cancelled) return true;
  return false;
}

bool Schedule::cancel(ActivityId id) {
  ++ends_epoch_;  // (leaving_order)
  Activity& a = acts_[id];
  if (a.state != ActivityState::Planned || a.cancelled) return false;
  auto unused = [&](BlockId b, MemId m) {
    const Copy* c = copy_at(b, m);
    return (!c || c->producer != id || c->users.empty()) && !read_after_eviction(id);
  };
  if (a.kind == ActivityKind::Transfer) {
    const Channel& ch = graph_->channels[a.channel];
    if (a.move || !unused(a.block, ch.to)) return false;
    withdraw_copy(a.block, ch.to, id);
    forget_user(mutable_copy(a.block, ch.from), id);
    for (ResourceId r : ch.resources) ++resource_version_[r];
  } else {
    const Job& job = pool_->job(a.job);
    const MemId m = graph_->computes[a.device].memory;
    for (BlockId b : job.inputs)
      if (pool_->block(b).consumed) return false;
    for (BlockId o : job.outputs)
      if (!unused(o, m)) return false;
    for (BlockId o : job.outputs) withdraw_copy(o, m, id);
    for (BlockId b : job.inputs) forget_user(mutable_copy(b, m), id);
  }
  touch(a);
  a.cancelled = true;
  a.duration = a.setup = 0;
  a.end = a.start;
  return true;
}

bool Schedule::retime(ActivityId id, Time duration) {
  ++ends_epoch_;  // (leaving_order)
  Activity& a = acts_[id];
  if (a.kind != ActivityKind::Exec || a.state != ActivityState::Planned || a.cancelled) return false;
  touch(a);
  a.duration = duration;
  a.setup = std::min(a.setup, duration);
  a.end = a.start + duration;
  Timeline& tl = device_tl_[a.device];
  if (!tl.items.empty() && tl.items.back() == id) tl.busy_until = a.end;
  return true;
}

Schedule::CancelCount Schedule::cancel_job(JobId j) {
  CancelCount n;
  const ActivityId e = pool_->activity(j);
  if (e != kNone && cancel(e)) ++n.execs;
  const ActivityList& ts = transfers_for(j);
  for (auto it = std::make_reverse_iterator(ts.end()); it != std::make_reverse_iterator(ts.begin()); ++it) {
    if (acts_[*it].cancelled) continue;
    if (cancel(*it)) {
      ++n.transfers;
      n.bytes += acts_[*it].bytes;
    } else {
      ++n.kept_transfers;
    }
  }
  return n;
}

void Schedule::on_started(ActivityId id, Time t) {
  ++ends_epoch_;  // (leaving_order)
  Activity& a = acts_[id];
  if (a.state == ActivityState::Failed) return;  // aborted by fail() before it was reported
  touch(a);
  a.state = ActivityState::Running;
  a.start = t;
  a.end = std::max(a.end, t);
}

void Schedule::on_finished(ActivityId id, Time t) {
  ++ends_epoch_;  // (leaving_order)
  Activity& a = acts_[id];
  if (a.state == ActivityState::Done || a.state == ActivityState::Failed) return;
  touch(a);
  if (a.state == ActivityState::Planned) a.start = t;
  a.state = ActivityState::Done;
  a.end = t;
  --unfinished_;
  if (a.kind == ActivityKind::Exec) --device_pending_[a.device];
  if (static_cast<std::size_t>(id) >= wait_head_.size()) return;
  for (std::int32_t n = wait_head_[static_cast<std::size_t>(id)]; n >= 0; n = wait_nodes_[static_cast<std::size_t>(n)].next) {
    const WaitNode& w = wait_nodes_[static_cast<std::size_t>(n)];
    std::vector<Leaving>& lv = leaving_[static_cast<std::size_t>(w.mem)];
    const auto it = first_leaving(lv, w.serial);
    if (it == lv.end() || it->serial != w.serial || it->after.empty()) continue;  // gone (fail(), a handover)
    Leaving& l = *it;
    if (std::find(l.after.begin(), l.after.end(), id) == l.after.end()) continue;
    l.after.erase(id);
    if (!l.after.empty()) continue;
    used_[l.mem] -= l.bytes;  // every activity it waited for has ended: the room is free
    touch_memory(l.mem);
    l.bytes = 0;
    std::size_t& dead = dead_leaving_[static_cast<std::size_t>(w.mem)];
    if (++dead * 2 > lv.size()) {
      std::erase_if(lv, [](const Leaving& e) { return e.after.empty(); });
      dead = 0;
    }
  }
  wait_head_[static_cast<std::size_t>(id)] = -1;
}

Schedule::Leaving& Schedule::add_leaving(Leaving l) {
  if (leaving_.size() < graph_->memories.size()) {
    leaving_.resize(graph_->memories.size());
    dead_leaving_.resize(graph_->memories.size(), 0);
  }
  l.serial = next_leaving_serial_++;
  std::vector<Leaving>& lv = leaving_[static_cast<std::size_t>(l.mem)];
  lv.push_back(std::move(l));
  return lv.back();
}

void Schedule::wait_for_end(Leaving& l, ActivityId a) {
  l.after.push_back(a);
  if (static_cast<std::size_t>(a) >= wait_head_.size()) wait_head_.resize(static_cast<std::size_t>(a) + 1, -1);
  std::int32_t& head = wait_head_[static_cast<std::size_t>(a)];
  wait_nodes_.push_back({l.mem, l.serial, head});
  head = static_cast<std::int32_t>(wait_nodes_.size() - 1);
}

// The latest end among a's dependencies, as the plain loop over a.deps gives it: the done
// ones are folded into done_end once and dropped (their ends no longer change).
Time Schedule::latest_dep_end(ActivityId id, const Activity& a) {
  OpenDeps& o = open_deps_[id];
  if (o.of_size != a.deps.size()) {
    o.of_size = a.deps.size();
    o.done_end = -kNever;
    o.open.assign(a.deps.begin(), a.deps.end());
  }
  Time t = o.done_end;
  std::size_t w = 0;
  for (const ActivityId p : o.open) {
    const Activity& d = acts_[p];
    if (d.state == ActivityState::Done) {
      o.done_end = std::max(o.done_end, d.end);
    } else {
      o.open[w++] = p;
    }
    t = std::max(t, d.end);
  }
  o.open.resize(w);
  return t;
}

void Schedule::reproject(Time now) {
  ++ends_epoch_;  // (leaving_order)
  // Over the activities not done yet, in id order (a dependency and a timeline predecessor
  // always have a smaller id), dropping the ones that finished since the last call.
  // Activities finish out of commit order, so "everything after the oldest unfinished
  // one" held ~10^5 finished ones in a long path-tracing run, walked after every event.
  std::size_t w = 0;
  for (std::size_t r = 0; r < pending_.size(); ++r) {
    const ActivityId id = pending_[r];
    Activity& a = acts_[id];
    if (a.state == ActivityState::Done || (a.state == ActivityState::Failed && !a.placeholder)) {
      if (a.deps.size() > kFewDeps) open_deps_.erase(id);
      continue;
    }
    if (a.placeholder) {  // aborted before it started (fail()): ends when its predecessors do
      Time s = now;
      bool settled = true;
      for (ActivityId p : a.timeline_prev) {
        s = std::max(s, acts_[p].end);
        settled = settled && (acts_[p].state == ActivityState::Done ||
                              (acts_[p].state == ActivityState::Failed && !acts_[p].placeholder));
      }
      a.start = a.end = s;
      if (settled) {
        a.placeholder = false;
        continue;
      }
      pending_[w++] = id;
      continue;
    }
    pending_[w++] = id;
    if (a.state == ActivityState::Running) {
      a.end = std::max(now, a.start + a.duration);
      continue;
    }
    Time s = now;
    if (a.deps.size() > kFewDeps) {
      s = std::max(s, latest_dep_end(id, a));
    } else {
      for (ActivityId p : a.deps) s = std::max(s, acts_[p].end);
    }
    for (ActivityId p : a.timeline_prev) s = std::max(s, acts_[p].end);
    a.start = s;
    if (s + a.duration < a.end) touch(a);  // earlier than planned: room on its node's timelines (node_epoch)
    a.end = s + a.duration;
  }
  pending_.resize(w);
  for (Timeline& tl : device_tl_)
    tl.busy_until = tl.items.empty() ? 0 : acts_[tl.items.back()].end;
  for (std::size_t r = 0; r < resource_tl_.size(); ++r) {
    Timeline& tl = resource_tl_[r];
    const Time nb = tl.items.empty() ? 0 : acts_[tl.items.back()].end;
    if (nb == tl.busy_until) continue;  // its channels' finish times stand (commits raise them)
    ++resource_version_[r];
    tl.busy_until = nb;
    resource_busy_changed(static_cast<ResourceId>(r));
  }
}

}  // namespace rayline
