#include "render/store/block_store.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <future>

#include "common/error.hpp"

namespace rayline::engine {

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

struct BlockStore::TimedRead {
  RawBlock raw;
  double t0 = 0, t1 = 0;  // since the store was created
};

struct BlockStore::Staged {
  std::uint32_t block = 0;
  std::future<TimedRead> read;  // std::async: its destructor waits for the read
};

BlockStore::BlockStore(const partition::BlockIndex& index, std::string dir, std::vector<std::uint64_t> footprint,
                       std::uint32_t material_count, trace::BvhQuality quality, int build_threads)
    : index_(index), dir_(std::move(dir)), footprint_(std::move(footprint)), materials_(material_count),
      quality_(quality), device_(build_threads), resident_(index.blocks.size()), copies_(index.blocks.size(), 0) {}

BlockStore::~BlockStore() {
  std::vector<std::unique_ptr<Staged>> s;
  {
    std::lock_guard lk(stage_mu_);
    s.swap(staged_);
  }
  // `s` waits here for reads still in flight (their results, or errors, are dropped).
}

double BlockStore::since_start() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
}

void BlockStore::busy(double t0, double t1, bool read) {
  busy_.emplace_back(t0, t1);
  if (read) reads_.emplace_back(t0, t1);
}

BlockStore::TimedRead BlockStore::timed_read(std::uint32_t block) const {
  TimedRead r;
  r.t0 = since_start();
  if (fail_read_ > 0 && reads_started_.fetch_add(1) + 1 == fail_read_)
    throw InputError(path(block), "payload", "read failed: Input/output error (injected by --fail-read)");
  r.raw = read_block_uncached(path(block));
  r.t1 = since_start();
  return r;
}

void BlockStore::read_ahead(std::uint32_t block) {
  if (block >= resident_.size() || resident(block)) return;
  std::unique_ptr<Staged> old;
  {
    std::lock_guard lk(stage_mu_);
    for (const auto& st : staged_)
      if (st->block == block) return;
    if (staged_.size() >= slots_) {
      old = std::move(staged_.front());
      staged_.erase(staged_.begin());
    }
    auto st = std::make_unique<Staged>();
    st->block = block;
    st->read = std::async(std::launch::async, [this, block] { return timed_read(block); });
    staged_.push_back(std::move(st));
  }
  if (old) {
    std::lock_guard lk(mu_);
    ++stats_.wasted_read_aheads;
  }
  // `old` (never used: its load was withdrawn or found the block resident) waits here.
}

std::string BlockStore::path(std::uint32_t block) const {
  return (std::filesystem::path(dir_) / index_.blocks.at(block).file).string();
}

std::shared_ptr<const trace::BlockGeometry> BlockStore::build(std::uint32_t block) {
  const std::string p = path(block);
  const double t_begin = since_start();
  std::unique_ptr<Staged> staged;
  {
    std::lock_guard lk(stage_mu_);
    for (auto it = staged_.begin(); it != staged_.end(); ++it)
      if ((*it)->block == block) {
        staged = std::move(*it);
        staged_.erase(it);
        break;
      }
  }
  // A read-ahead of this block: wait for it (errors are thrown here, as a direct read's).
  TimedRead tr = staged ? staged->read.get() : timed_read(block);
  RawBlock raw = std::move(tr.raw);
  const double read_s = tr.t1 - tr.t0;
  if (raw.header.block_id != block)
    throw InputError(p, "block_id", "holds block " + std::to_string(raw.header.block_id) + ", expected " +
                                        std::to_string(block));
  const partition::BlockInfo& info = index_.blocks[block];
  if (raw.header.triangle_count != info.triangles || raw.header.payload_crc32 != info.payload_crc32)
    throw InputError(p, "payload_crc32", "does not match blocks.json (block file from another partition?)");
  for (std::uint64_t i = 0; i < raw.header.triangle_count; ++i) {
    std::uint32_t m = 0;
    std::memcpy(&m, raw.payload.data() + i * partition::kRecordBytes + 36, 4);
    if (m >= materials_)
      throw InputError(p, "material", "triangle " + std::to_string(i) + " uses material " + std::to_string(m) +
                                          " but the scene has " + std::to_string(materials_));
  }
  const std::int64_t embree_before = device_.embree_bytes();
  const std::uint64_t started_before = builds_started_.fetch_add(1);
  const bool alone_at_start = builds_active_.fetch_add(1) == 0;
  auto t0 = std::chrono::steady_clock::now();
  auto g = std::make_shared<const trace::BlockGeometry>(device_, block, raw.payload, raw.header.triangle_count, quality_,
                                                        &pool_);
  const double build_s = seconds_since(t0);
  // Another loader's build overlapping this one would blur the Embree delta below.
  const bool alone = alone_at_start && builds_started_.load() == started_before + 1;
  builds_active_.fetch_sub(1);
  const double t_end = since_start();
  // The Embree delta is this block's BVH when no other build overlapped it (several
  // loaders); overlapped builds are not measured.
  const auto measured = static_cast<double>(g->array_bytes()) +
                        static_cast<double>(std::max<std::int64_t>(0, device_.embree_bytes() - embree_before));
  std::lock_guard lk(mu_);
  ++stats_.loads;
  stats_.bytes_read += raw.file_bytes;
  (raw.mode == ReadMode::Direct ? stats_.direct_reads : stats_.buffered_reads) += 1;
  stats_.read_seconds += read_s;
  if (staged) ++stats_.read_aheads;
  busy(tr.t0, tr.t1, true);
  busy(std::max(t_begin, tr.t1), t_end, false);  // waiting for a read-ahead is in the read's interval
  stats_.build_seconds += build_s;
  if (footprint_[block] > 0 && alone)
    stats_.worst_footprint_ratio = std::max(stats_.worst_footprint_ratio, measured / double(footprint_[block]));
  return g;
}

void BlockStore::load(std::uint32_t block) {
  {
    std::lock_guard lk(mu_);
    ++copies_.at(block);
    if (resident_[block]) return;
  }
  std::shared_ptr<const trace::BlockGeometry> g;
  try {
    g = build(block);
  } catch (...) {  // (the load did not happen: the plan may try it again)
    std::lock_guard lk(mu_);
    --copies_[block];
    throw;
  }
  std::lock_guard lk(mu_);
  if (resident_[block]) return;
  resident_[block] = std::move(g);
  stats_.resident_bytes += footprint_[block];
  stats_.peak_resident_bytes = std::max(stats_.peak_resident_bytes, stats_.resident_bytes);
  stats_.peak_embree_bytes = device_.peak_embree_bytes();
}

void BlockStore::insert(std::uint32_t block, std::span<const unsigned char> records) {
  const partition::BlockInfo& info = index_.blocks.at(block);
  const std::string what = "block " + std::to_string(block) + " received from another rank";
  if (records.size() != info.triangles * partition::kRecordBytes ||
      partition::crc32_update(0, records) != info.payload_crc32)
    throw InputError(what, "payload_crc32", "does not match blocks.json");
  for (std::uint64_t i = 0; i < info.triangles; ++i) {
    std::uint32_t m = 0;
    std::memcpy(&m, records.data() + i * partition::kRecordBytes + 36, 4);
    if (m >= materials_) throw InputError(what, "material", "triangle " + std::to_string(i) + " uses material " + std::to_string(m));
  }
  {
    std::lock_guard lk(mu_);
    ++copies_.at(block);
    if (resident_[block]) return;
  }
  const double t0 = since_start();
  auto g = std::make_shared<const trace::BlockGeometry>(device_, block, records, info.triangles, quality_, &pool_);
  std::lock_guard lk(mu_);
  busy(t0, since_start(), false);
  stats_.build_seconds += since_start() - t0;
  if (resident_[block]) return;
  resident_[block] = std::move(g);
  stats_.resident_bytes += footprint_[block];
  stats_.peak_resident_bytes = std::max(stats_.peak_resident_bytes, stats_.resident_bytes);
  stats_.peak_embree_bytes = device_.peak_embree_bytes();
}

void BlockStore::evict(std::uint32_t block) {
  std::shared_ptr<const trace::BlockGeometry> g;
  std::lock_guard lk(mu_);
  if (copies_.at(block) > 0) --copies_[block];
  if (copies_[block] > 0 || !resident_[block]) return;
  g.swap(resident_[block]);
  stats_.resident_bytes -= footprint_[block];
  ++stats_.evictions;
  // `g` is released here, or by the last job still holding it (none, if the plan is kept).
}

std::shared_ptr<const trace::BlockGeometry> BlockStore::get(std::uint32_t block) {
  {
    std::lock_guard lk(mu_);
    if (resident_.at(block)) return resident_[block];
    ++stats_.unplanned_loads;
  }
  load(block);
  std::lock_guard lk(mu_);
  --copies_[block];  // not a plan copy: the next planned eviction may free it
  return resident_[block];
}

bool BlockStore::resident(std::uint32_t block) const {
  std::lock_guard lk(mu_);
  return resident_.at(block) != nullptr;
}

namespace {
// Length of the union of intervals.
double union_length(std::vector<std::pair<double, double>> v) {
  std::sort(v.begin(), v.end());
  double total = 0, lo = 0, hi = -1;
  for (auto [a, b] : v) {
    if (b <= a) continue;
    if (a > hi) {
      if (hi > lo) total += hi - lo;
      lo = a, hi = b;
    } else {
      hi = std::max(hi, b);
    }
  }
  if (hi > lo) total += hi - lo;
  return total;
}
}  // namespace

BlockStoreStats BlockStore::stats() const {
  std::lock_guard lk(mu_);
  BlockStoreStats s = stats_;
  s.recycled_arrays = pool_.reuses();
  s.channel_busy_seconds = union_length(busy_);
  s.disk_read_busy_seconds = union_length(reads_);
  return s;
}

}  // namespace rayline::engine
