// Test support: options for a small render of the built-in Cornell-like scene (8 blocks,
// 2 worker threads, small batches so even a tiny image makes many jobs and merges).
#pragma once
#include <cstdint>
#include <string>

#include "render/engine/renderer.hpp"

namespace rayline::testing {

inline engine::RenderOptions small_render(int width, int height, int spp, std::uint64_t seed,
                                          std::uint32_t path_cap, const std::string& gpu = "auto") {
  engine::RenderOptions o;
  o.width = width;
  o.height = height;
  o.spp = spp;
  o.threads = 2;
  o.seed = seed;
  o.blocks = 8;
  o.gpu = gpu;
  o.batching.min_batch = 256;
  o.batching.path_cap = path_cap;
  o.keep_schedule_outputs = false;
  return o;
}

}  // namespace rayline::testing
