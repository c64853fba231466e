// The schedulers by name, for every engine (sim and render) and the command line:
// "gmb" (the paper, Sec. 4.2-4.3), "gmb-ca" (completion-aware GMB), "budge" (Budge 2009),
// "loadanyonce" (Navrátil 2014), "rayline" (Rayline's own, docs/rayline-policy.md). The names are known here and nowhere else: callers parse
// a name into a SchedulerChoice (and report an unknown one in their own terms).
#pragma once
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sched/policy/scheduler.hpp"

namespace rayline {

enum class SchedulerKind : std::uint8_t { Gmb, GmbCompletionAware, Budge, LoadAnyOnce, Rayline };

// Every kind's name, in the factory's order ("gmb, gmb-ca, budge, loadanyonce, rayline").
inline constexpr std::string_view kSchedulerNames[] = {"gmb", "gmb-ca", "budge", "loadanyonce", "rayline"};
std::string_view scheduler_name(SchedulerKind kind);
std::optional<SchedulerKind> scheduler_kind(std::string_view name);
// The names joined with `separator` (for help texts and error messages).
std::string scheduler_names(std::string_view separator = ", ");

// What to plan with. `horizon` is k (Sec. 4.2) and `aging` the seconds a job may wait
// before it jumps the queue (Sec. 4.3; < 0: GMB's default, 5k and at least 1 s; kNever:
// off); `adaptive_aging` is GmbOptions::adaptive_aging. Rayline's policy plans k/4 ahead,
// without the rules in `rayline_off`; the baselines use none of them.
struct SchedulerChoice {
  SchedulerKind kind = SchedulerKind::Gmb;
  Time horizon = 2.0;
  Time aging = -1;
  bool adaptive_aging = false;
  unsigned rayline_off = 0;  // Rayline's rules switched off (rayline_rules_off)
  unsigned rayline_on = 0;   // ... and switched on (those off by default, kRaylineRulesOffByDefault)
  // GMB's plan cells (GmbOptions::cell_nodes, plan_cells.hpp): at most this many nodes per
  // cell, 0 for one cell. The default, 32, is a rack of the generated scale platforms: a
  // cluster of up to 32 nodes (the paper's 8 included) is planned as the paper describes.
  int plan_cell = 32;
};
std::unique_ptr<Scheduler> make_scheduler(const SchedulerChoice& choice);
// Warm start (docs/simulator.md): where the policy's steady state keeps the scene blocks,
// per block (in id order, `scene_bytes` their sizes) the memories holding a copy; empty
// for the policies whose caches converge to the blocks used most (the default placement).
std::vector<std::vector<MemId>> warm_placement(const SchedulerChoice& choice, const DeviceGraph& g,
                                               const std::vector<Bytes>& scene_bytes);
// Per job type (JobTypeId): the most queue bytes one ray job may take by merging, for the
// policies that size jobs to devices (Rayline's rule 7, job_size.hpp); empty: no cap.
std::vector<Bytes> job_caps(const SchedulerChoice& choice, const DeviceGraph& g);
// By name (the renderer's options): InputError for a name not listed above.
std::unique_ptr<Scheduler> make_scheduler(const std::string& name, Time horizon, Time aging = -1,
                                          bool adaptive_aging = false);

}  // namespace rayline
