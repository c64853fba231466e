#include "render/embree/array_pool.hpp"

#include <algorithm>

namespace rayline::trace {

template <class T>
std::vector<T> ArrayPool::take(std::vector<std::vector<T>>& free, std::size_t n) {
  std::vector<T> out;
  {
    std::lock_guard lk(mu_);
    // The smallest idle array that is large enough (blocks are of about equal size).
    auto best = free.end();
    for (auto it = free.begin(); it != free.end(); ++it)
      if (it->capacity() >= n && it->capacity() <= n + n / 8 + 1024 && (best == free.end() || it->capacity() < best->capacity())) best = it;
    if (best != free.end()) {
      out = std::move(*best);
      free.erase(best);
      ++reuses_;
    }
  }
  out.resize(n);  // within capacity when recycled: no allocation, pages already mapped
  return out;
}

template <class T>
void ArrayPool::put(std::vector<std::vector<T>>& free, std::vector<T>&& v, std::size_t keep) {
  if (v.capacity() == 0) return;
  v.clear();
  std::lock_guard lk(mu_);
  if (keep == 0) return;
  if (free.size() < keep) {
    free.push_back(std::move(v));
    return;
  }
  // Full: keep the larger arrays (more likely to fit the next block).
  auto smallest = std::min_element(free.begin(), free.end(),
                                   [](const auto& a, const auto& b) { return a.capacity() < b.capacity(); });
  if (smallest->capacity() < v.capacity()) std::swap(*smallest, v);
}

std::vector<float> ArrayPool::floats(std::size_t n) { return take(floats_, n); }
std::vector<std::uint32_t> ArrayPool::uints(std::size_t n) { return take(uints_, n); }
void ArrayPool::give(std::vector<float>&& v) { put(floats_, std::move(v), keep_floats_); }
void ArrayPool::give(std::vector<std::uint32_t>&& v) { put(uints_, std::move(v), keep_uints_); }

std::size_t ArrayPool::idle_bytes() const {
  std::lock_guard lk(mu_);
  std::size_t b = 0;
  for (const auto& v : floats_) b += v.capacity() * sizeof(float);
  for (const auto& v : uints_) b += v.capacity() * sizeof(std::uint32_t);
  return b;
}

std::size_t ArrayPool::reuses() const {
  std::lock_guard lk(mu_);
  return reuses_;
}

}  // namespace rayline::trace
