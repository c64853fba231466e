// The Schedule's activities (Sec. 4.1's T-jobs and E-jobs), indexed by ActivityId and only
// ever appended. A std::vector doubled its buffer as a run grew: every element was moved
// again and the fresh pages zeroed by the kernel, ≈ 6 % of a long simulation (a Boeing run
// of 88 k activities under Rayline's policy, perf). Fixed-size chunks never move, and a
// reference stays valid while the store grows.
#pragma once
#include <cstddef>
#include <memory>
#include <new>
#include <utility>
#include <vector>

namespace rayline {

template <class T, std::size_t kChunkLog2 = 12>
class ChunkedStore {
 public:
  static constexpr std::size_t kChunk = std::size_t{1} << kChunkLog2;

  ChunkedStore() = default;
  ChunkedStore(const ChunkedStore& o) {
    for (std::size_t i = 0; i < o.size_; ++i) push_back(T(o[i]));
  }
  ChunkedStore& operator=(const ChunkedStore& o) {
    if (this != &o) {
      clear();
      for (std::size_t i = 0; i < o.size_; ++i) push_back(T(o[i]));
    }
    return *this;
  }
  ChunkedStore(ChunkedStore&& o) noexcept : chunks_(std::move(o.chunks_)), size_(std::exchange(o.size_, 0)) {}
  ChunkedStore& operator=(ChunkedStore&& o) noexcept {
    if (this != &o) {
      clear();
      chunks_ = std::move(o.chunks_);
      size_ = std::exchange(o.size_, 0);
    }
    return *this;
  }
  ~ChunkedStore() { clear(); }

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  T& operator[](std::size_t i) { return slot(i); }
  const T& operator[](std::size_t i) const { return const_cast<ChunkedStore*>(this)->slot(i); }

  T& push_back(T&& v) {
    if (size_ == chunks_.size() * kChunk) chunks_.emplace_back(new Raw[kChunk]);
    T* p = ::new (static_cast<void*>(&chunks_.back()[size_ % kChunk])) T(std::move(v));
    ++size_;
    return *p;
  }

  void clear() {
    for (std::size_t i = 0; i < size_; ++i) slot(i).~T();
    chunks_.clear();
    size_ = 0;
  }

 private:
  struct alignas(T) Raw {
    std::byte bytes[sizeof(T)];
  };
  T& slot(std::size_t i) {
    return *std::launder(reinterpret_cast<T*>(&chunks_[i >> kChunkLog2][i & (kChunk - 1)]));
  }
  std::vector<std::unique_ptr<Raw[]>> chunks_;
  std::size_t size_ = 0;
};

}  // namespace rayline
