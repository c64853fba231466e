// The job graph of path tracing (Sec. 5.1, Fig. 3), as the simulator's path-tracing
// workload builds it:
//
//   image request (client) ─► GenerateRays ─► RayQueue_b ─► RayIntersect(SceneData_b, RayQueue_b)
//        │ miss: RayQueue_n (neighbour n) ◄──────────────────────┤ escape: sample record
//        │                                                      ▼ hit records
//        │                                  Shade ─► ShadowRayQueue_b + RayQueue_b (survivors)
//        │                                    │ path ends (roulette): sample record
//        │    ShadowIntersect(SceneData_b, ShadowRayQueue_b) ─► lit: sample record; on: ShadowRayQueue_n
//        ▼                                                          ▼
//   client framebuffer ◄── AdditiveCompose(partial framebuffers) ◄── Accumulate(sample records)
//
// Every queue lives on the memory device of the job that produced it and merges on arrival
// with a queued job's queue of the same kind and block there (Sec. 5.1). Sample records
// and partial framebuffers are Framebuffer data: they never move except into
// AdditiveCompose (Placer::may_fetch), so Accumulate runs where its records are.
#pragma once
#include <array>
#include <cstdint>
#include <string_view>

#include "sched/core/data_block.hpp"
#include "workload/scene_profile.hpp"

namespace rayline {

enum class PtJob : std::uint8_t { Generate, Intersect, Shade, Shadow, Accumulate, Compose };
inline constexpr int kPtJobCount = 6;
// Job type names of the platform files (platforms/README.md, "Job types").
inline constexpr std::array<std::string_view, kPtJobCount> kPtJobTypeNames = {
    "GenerateRays", "RayIntersect", "Shade", "ShadowIntersect", "Accumulate", "AdditiveCompose"};

// The data kind of the queue each job consumes.
// The most clients a path-tracing run takes: ray keys give the client 10 bits
// (SplitContext::key in path_trace_model.hpp).
inline constexpr int kMaxPtClients = 1023;

// Bytes of one record of the queue a job of kind k consumes (a ray, a hit record, a shadow
// ray, a sample contribution; 1 for the other kinds).
inline Bytes pt_record_bytes(const SceneProfile& p, PtJob k) {
  switch (k) {
    case PtJob::Intersect: return p.ray_bytes;
    case PtJob::Shade: return p.hit_bytes;
    case PtJob::Shadow: return p.shadow_ray_bytes;
    case PtJob::Accumulate: return p.sample_bytes;
    default: return 1;
  }
}

inline DataKind pt_queue_kind(PtJob j) {
  switch (j) {
    case PtJob::Generate: return DataKind::Generic;
    case PtJob::Intersect: return DataKind::RayQueue;
    case PtJob::Shade: return DataKind::RayQueue;  // hit records
    case PtJob::Shadow: return DataKind::ShadowRayQueue;
    case PtJob::Accumulate:
    case PtJob::Compose: return DataKind::Framebuffer;
  }
  return DataKind::Generic;
}

// Jobs whose rays count as traced (throughput: rays intersected per second).
inline bool pt_traces_rays(PtJob j) { return j == PtJob::Intersect || j == PtJob::Shadow; }

}  // namespace rayline
