// A short list of activity ids kept inside the Activity (Sec. 4.1's dependencies and
// timeline predecessors) and inside each copy of a block (its users). An E-job depends on the T-jobs that bring its inputs and a T-job
// on the hop before it, so nearly every list has at most kInline entries; those need no
// allocation. With two std::vector lists, every committed T-job and E-job allocated:
// ≈ 530 allocations per plan of the bench instance. Inline, a warm plan takes
// 1.0 % fewer instructions and an activity 24 bytes less memory. Longer lists move to the
// heap, with doubling growth.
#pragma once
#include <algorithm>
#include <cstdint>
#include <initializer_list>
#include <memory>

#include "sched/core/types.hpp"

namespace rayline {

class ActivityList {
 public:
  static constexpr std::uint32_t kInline = 3;

  ActivityList() = default;
  ActivityList(std::initializer_list<ActivityId> ids) { append(ids.begin(), ids.end()); }
  ActivityList(const ActivityList& o) { append(o.begin(), o.end()); }
  ActivityList(ActivityList&& o) noexcept { take(o); }
  ActivityList& operator=(const ActivityList& o) {
    if (this != &o) {
      size_ = 0;
      append(o.begin(), o.end());
    }
    return *this;
  }
  ActivityList& operator=(ActivityList&& o) noexcept {
    if (this != &o) {
      release();
      take(o);
    }
    return *this;
  }
  ~ActivityList() { release(); }

  std::uint32_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  std::uint32_t capacity() const { return cap_; }
  bool on_heap() const { return cap_ > kInline; }
  const ActivityId* data() const { return on_heap() ? heap_ : inline_; }
  ActivityId* data() { return on_heap() ? heap_ : inline_; }
  const ActivityId* begin() const { return data(); }
  const ActivityId* end() const { return data() + size_; }
  ActivityId* begin() { return data(); }
  ActivityId* end() { return data() + size_; }
  ActivityId operator[](std::uint32_t i) const { return data()[i]; }
  ActivityId& operator[](std::uint32_t i) { return data()[i]; }

  void reserve(std::size_t n) {
    if (n > cap_) grow(n);
  }
  void push_back(ActivityId id) {
    if (size_ == cap_) grow(std::size_t{cap_} * 2);
    data()[size_++] = id;
  }
  template <class It>
  void append(It first, It last) {
    const auto n = static_cast<std::size_t>(std::distance(first, last));
    reserve(size_ + n);
    std::copy(first, last, data() + size_);
    size_ += static_cast<std::uint32_t>(n);
  }

  // Removes every occurrence of id, keeping the order of the rest (std::erase).
  void erase(ActivityId id) { size_ = static_cast<std::uint32_t>(std::remove(begin(), end(), id) - begin()); }
  // Removes every id for which pred holds, keeping the order of the rest (std::erase_if).
  template <class Pred>
  void erase_if(Pred pred) {
    size_ = static_cast<std::uint32_t>(std::remove_if(begin(), end(), pred) - begin());
  }

  friend bool operator==(const ActivityList& a, const ActivityList& b) {
    return std::equal(a.begin(), a.end(), b.begin(), b.end());
  }

 private:
  union {
    ActivityId inline_[kInline];
    ActivityId* heap_;
  };
  std::uint32_t size_ = 0;
  std::uint32_t cap_ = kInline;

  void grow(std::size_t n) {
    auto* p = new ActivityId[n];
    std::copy(begin(), end(), p);
    release();
    heap_ = p;
    cap_ = static_cast<std::uint32_t>(n);
  }
  void release() {
    if (on_heap()) delete[] heap_;
    cap_ = kInline;
  }
  void take(ActivityList& o) {  // (this is empty and inline)
    size_ = o.size_;
    if (o.on_heap()) {
      heap_ = o.heap_;
      cap_ = o.cap_;
      o.cap_ = kInline;
    } else {
      std::copy(o.inline_, o.inline_ + o.size_, inline_);
    }
    o.size_ = 0;
  }
};

}  // namespace rayline
