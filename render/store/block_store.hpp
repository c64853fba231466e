// The RAM side of the disk→RAM channel ("Memory devices and channels of this
// machine"): scene blocks resident in host memory, each as a traceable BlockGeometry.
// A block enters only through a planned T-job (load) and leaves only through a planned
// eviction, so what is resident mirrors the Schedule's copies on the RAM memory device,
// and the bytes held stay within the memory budget the plan respects. The plan may hold
// two copies of one block in sequence (evicted at the start of some activity, fetched
// again by a T-job that can run before it): the store keeps one physical copy and counts
// the plan's copies, freeing it when the last one is evicted.
#pragma once
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "render/store/block_reader.hpp"
#include "render/partition/partition.hpp"
#include "render/embree/array_pool.hpp"
#include "render/embree/block_geometry.hpp"

namespace rayline::engine {

struct BlockStoreStats {
  std::uint64_t loads = 0, evictions = 0, unplanned_loads = 0;
  std::uint64_t bytes_read = 0;
  std::uint64_t direct_reads = 0, buffered_reads = 0;
  std::uint64_t read_aheads = 0, wasted_read_aheads = 0;  // loads served by a read-ahead; reads never used
  std::uint64_t recycled_arrays = 0;  // block arrays taken from the ArrayPool (no fresh pages)
  double read_seconds = 0, build_seconds = 0;
  // Seconds the disk->RAM channel was busy (reading or building; the union, since a
  // read-ahead overlaps the previous build) and reading, since the store was created.
  double channel_busy_seconds = 0, disk_read_busy_seconds = 0;
  std::uint64_t resident_bytes = 0, peak_resident_bytes = 0;  // footprints of resident blocks
  std::int64_t peak_embree_bytes = 0;
  double worst_footprint_ratio = 0;  // measured bytes / planned bytes, max over loads
};

class BlockStore {
 public:
  // `footprint[b]`: the bytes the plan charges for block b in RAM (SceneData size).
  BlockStore(const partition::BlockIndex& index, std::string dir, std::vector<std::uint64_t> footprint,
             std::uint32_t material_count, trace::BvhQuality quality = trace::BvhQuality::Medium,
             int build_threads = 1);
  ~BlockStore();

  // The T-job: read (uncached) + verify + build the BVH. Thread-safe. Throws InputError on
  // a bad block file.
  void load(std::uint32_t block);
  void evict(std::uint32_t block);
  // A RAM->RAM T-job's arrival (a distributed render, render/mpi/README.md): the block built
  // from the records another rank's RAM copy sent (BlockGeometry::records), checked against
  // blocks.json (size and CRC-32) as a file read is; not counted as a (disk) load. Throws
  // InputError.
  void insert(std::uint32_t block, std::span<const unsigned char> records);
  // Starts reading `block`'s file into a staging buffer on a background thread, so the next
  // load() of it only builds the BVH (a T-job's disk half overlapping its predecessor's CPU
  // half). Touches no memory the plan accounts for: one staged file at most (its bytes are
  // part of the documented overhead); a newer read-ahead replaces an unused one. Errors
  // surface in load(). Does nothing for a resident block. With several loaders (disk->RAM
  // channels, set_staging_slots) each may have one staged file: the oldest unused one is
  // replaced.
  void read_ahead(std::uint32_t block);
  void set_staging_slots(std::size_t n) { slots_ = n < 1 ? 1 : n; }
  // Fault injection (docs/faults.md): the n-th read of a block file (1-based, read-aheads
  // included) fails once, as an I/O error would (0: none). A failed load() leaves the
  // store as it was, so the runtime can plan the load again.
  void fail_read(std::uint64_t n) { fail_read_ = n; }
  // The resident geometry; when the block is not resident (a plan violation, counted) it
  // is loaded on the spot so the image stays right.
  std::shared_ptr<const trace::BlockGeometry> get(std::uint32_t block);
  bool resident(std::uint32_t block) const;

  BlockStoreStats stats() const;
  const trace::EmbreeDevice& device() const { return device_; }
  std::string path(std::uint32_t block) const;

  // Bytes per triangle the plan charges: Embree input arrays (vertices 36, indices 12,
  // material 4) plus the BVH, measured with margin (README, "Memory"): about 80 B for the
  // medium/high builders, about 105 B for the low-quality builder.
  static std::uint64_t bytes_per_triangle(trace::BvhQuality q) { return q == trace::BvhQuality::Low ? 52 + 120 : 52 + 88; }
  static std::uint64_t footprint_of(std::uint64_t triangles, trace::BvhQuality q) {
    return 4096 + triangles * bytes_per_triangle(q);
  }

 private:
  struct TimedRead;
  TimedRead timed_read(std::uint32_t block) const;
  std::shared_ptr<const trace::BlockGeometry> build(std::uint32_t block);
  double since_start() const;
  void busy(double t0, double t1, bool read);  // records a channel interval (under mu_)
  const partition::BlockIndex& index_;
  std::string dir_;
  std::vector<std::uint64_t> footprint_;
  std::uint32_t materials_;
  trace::BvhQuality quality_;
  trace::EmbreeDevice device_;
  trace::ArrayPool pool_;  // before resident_: blocks give their arrays back when dropped
  mutable std::mutex mu_;
  std::vector<std::shared_ptr<const trace::BlockGeometry>> resident_;
  std::vector<int> copies_;  // plan copies loaded and not yet evicted, per block
  BlockStoreStats stats_;
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
  std::vector<std::pair<double, double>> busy_, reads_;  // channel / read intervals, merged at stats()
  // The staged read-ahead (declared last: its thread uses the members above, and the
  // future's destructor waits for it).
  struct Staged;
  mutable std::mutex stage_mu_;
  std::vector<std::unique_ptr<Staged>> staged_;  // oldest first, at most slots_
  std::size_t slots_ = 1;
  std::uint64_t fail_read_ = 0;
  mutable std::atomic<std::uint64_t> reads_started_{0};
  std::atomic<std::uint64_t> builds_started_{0};
  std::atomic<int> builds_active_{0};
};

}  // namespace rayline::engine
