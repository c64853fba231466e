// Recycles the large per-block arrays (vertices, indices, materials) of evicted blocks for
// the next load (out-of-core speed). Out of core every load builds a block from
// scratch; freshly allocated arrays are mapped page by page on first touch, and on the
// development VM a 4 KiB page fault costs ≈ 17 µs, so the arrays of one 630 k-triangle
// block (33 MB) cost ≈ 140 ms of faults, more than its BVH build. Recycled arrays are
// already mapped. The pool keeps at most `keep` idle arrays of each kind, so what it holds
// outside the budget is bounded (README, "Memory": part of the documented overhead): by
// default one block's arrays (one vertex array, an index and a material array).
#pragma once
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <vector>

namespace rayline::trace {

class ArrayPool {
 public:
  ArrayPool(std::size_t keep_floats = 2, std::size_t keep_uints = 4) : keep_floats_(keep_floats), keep_uints_(keep_uints) {}
  // An array of `n` elements (contents unspecified), recycled when one large enough is idle.
  // Only an idle array at most 1/8 larger than asked is recycled, so a block never holds
  // much more than the bytes the plan charges for it.
  std::vector<float> floats(std::size_t n);
  std::vector<std::uint32_t> uints(std::size_t n);
  void give(std::vector<float>&& v);
  void give(std::vector<std::uint32_t>&& v);
  // Bytes of the idle arrays held now (capacity).
  std::size_t idle_bytes() const;
  std::size_t reuses() const;

 private:
  template <class T>
  std::vector<T> take(std::vector<std::vector<T>>& free, std::size_t n);
  template <class T>
  void put(std::vector<std::vector<T>>& free, std::vector<T>&& v, std::size_t keep);

  mutable std::mutex mu_;
  std::size_t keep_floats_, keep_uints_;
  std::size_t reuses_ = 0;
  std::vector<std::vector<float>> floats_;
  std::vector<std::vector<std::uint32_t>> uints_;
};

}  // namespace rayline::trace
