// Data blocks of Sec. 3.2/5.1: SceneData, RayQueue, ShadowRayQueue, Framebuffer (+ Generic
// for synthetic job sets). Sizes are bytes; |w| in Eq. 1 and Eq. 2.
#pragma once
#include <array>
#include <string>
#include <string_view>

#include "sched/core/types.hpp"

namespace rayline {

enum class DataKind : std::uint8_t { SceneData, RayQueue, ShadowRayQueue, Framebuffer, Generic };
inline constexpr int kDataKindCount = 5;
inline constexpr std::array<std::string_view, kDataKindCount> kDataKindNames = {
    "SceneData", "RayQueue", "ShadowRayQueue", "Framebuffer", "Generic"};

bool parse_data_kind(std::string_view name, DataKind& out);
inline std::string_view to_string(DataKind k) { return kDataKindNames[static_cast<int>(k)]; }

// Sec. 5.1: ray queues are consumed by the job that processes them and *move* between
// memory devices (merging on arrival); SceneData is copied and cached; framebuffers move
// only for AdditiveCompose.
inline bool is_consumed_by_use(DataKind k) {
  return k == DataKind::RayQueue || k == DataKind::ShadowRayQueue;
}

struct DataBlock {
  std::string name;
  DataKind kind = DataKind::Generic;
  Bytes bytes = 0;
  std::int32_t scene_block = kNone;  // for (Shadow)RayQueue: the SceneData block it belongs to
  bool consumed = false;             // removed from memory when its consuming E-job ends
  bool movable = true;               // false: never transferred (e.g. a framebuffer before compose)
};

}  // namespace rayline
