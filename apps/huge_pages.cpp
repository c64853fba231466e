#include "apps/huge_pages.hpp"

#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <malloc.h>
#include <new>
#include <sys/mman.h>
#include <unistd.h>

namespace {
std::atomic<bool> g_advise{false};
constexpr std::size_t kMinBytes = std::size_t{4} << 20;  // smaller ones: not worth a syscall
constexpr std::uintptr_t kHugePage = std::uintptr_t{2} << 20;

// The whole huge pages inside [p, p + n): glibc serves such sizes from their own anonymous
// mappings, so the advice covers nothing but this allocation.
void advise(void* p, std::size_t n) {
  const auto b = reinterpret_cast<std::uintptr_t>(p);
  const std::uintptr_t first = (b + kHugePage - 1) & ~(kHugePage - 1), last = (b + n) & ~(kHugePage - 1);
  if (last > first) (void)::madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
}
// malloc's main heap (small allocations: ray counts, names, lists) grows by sbrk; once it
// has grown past the part already advised, the rest up to its end is advised too. glibc
// extends it kTopPad at a time, so the advice reaches pages before they are first touched.
constexpr std::size_t kTopPad = std::size_t{64} << 20;
std::atomic<std::uintptr_t> g_heap_advised{0};
void advise_heap() {
  const auto end = reinterpret_cast<std::uintptr_t>(::sbrk(0)) & ~(kHugePage - 1);
  std::uintptr_t done = g_heap_advised.load(std::memory_order_relaxed);
  if (end <= done + kHugePage) return;
  if (!g_heap_advised.compare_exchange_strong(done, end)) return;
  (void)::madvise(reinterpret_cast<void*>(done), end - done, MADV_HUGEPAGE);
}
}  // namespace

namespace rayline::cli {
void use_huge_pages_for_large_allocations() {
  (void)::mallopt(M_TOP_PAD, static_cast<int>(kTopPad));
  g_heap_advised.store((reinterpret_cast<std::uintptr_t>(::sbrk(0)) + kHugePage - 1) & ~(kHugePage - 1));
  g_advise.store(true, std::memory_order_relaxed);
}
}  // namespace rayline::cli

// Sanitizers bring their own allocators: these replacements are left out of those builds.
#if !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
void* operator new(std::size_t n) {
  void* p = std::malloc(n ? n : 1);
  if (!p) throw std::bad_alloc();
  if (g_advise.load(std::memory_order_relaxed)) {
    if (n >= kMinBytes) advise(p, n);
    else advise_heap();
  }
  return p;
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#endif
