#include "sched/policy/scheduler_factory.hpp"

#include <stdexcept>

#include "common/error.hpp"
#include "sched/policy/budge.hpp"
#include "sched/policy/gmb/gmb_scheduler.hpp"
#include "sched/policy/load_any_once.hpp"
#include "sched/policy/rayline/job_size.hpp"
#include "sched/policy/rayline/rayline_scheduler.hpp"

namespace rayline {

std::string_view scheduler_name(SchedulerKind kind) { return kSchedulerNames[static_cast<std::size_t>(kind)]; }

std::optional<SchedulerKind> scheduler_kind(std::string_view name) {
  for (std::size_t i = 0; i < std::size(kSchedulerNames); ++i)
    if (kSchedulerNames[i] == name) return static_cast<SchedulerKind>(i);
  return std::nullopt;
}

std::string scheduler_names(std::string_view separator) {
  std::string out;
  for (std::string_view n : kSchedulerNames) (out.empty() ? out : out.append(separator)).append(n);
  return out;
}

std::unique_ptr<Scheduler> make_scheduler(const SchedulerChoice& c) {
  switch (c.kind) {
    case SchedulerKind::Gmb:
    case SchedulerKind::GmbCompletionAware:
      return std::make_unique<GmbScheduler>(GmbOptions{.horizon = c.horizon,
                                                       .aging = c.aging,
                                                       .adaptive_aging = c.adaptive_aging,
                                                       .completion_aware = c.kind == SchedulerKind::GmbCompletionAware,
                                                       .cell_nodes = c.plan_cell});
    case SchedulerKind::Budge: return std::make_unique<BudgeScheduler>();
    case SchedulerKind::LoadAnyOnce: return std::make_unique<LoadAnyOnceScheduler>();
    // Rayline's policy places each job where it finishes first, so it looks a quarter as
    // far ahead as GMB's k (0.5 s at the default k = 2 s; docs/rayline-policy.md, rule 6).
    case SchedulerKind::Rayline: return std::make_unique<RaylineScheduler>(rayline_options(c.horizon / 4, c.rayline_off, c.rayline_on));
  }
  throw std::logic_error("make_scheduler: no such scheduler kind");
}

std::vector<std::vector<MemId>> warm_placement(const SchedulerChoice& c, const DeviceGraph& g,
                                               const std::vector<Bytes>& scene_bytes) {
  if (c.kind != SchedulerKind::Rayline || !rayline_options(c.horizon / 4, c.rayline_off, c.rayline_on).ownership) return {};
  return ownership_warm_placement(plan_ownership(g, scene_bytes), g, scene_bytes);
}

std::vector<Bytes> job_caps(const SchedulerChoice& c, const DeviceGraph& g) {
  if (c.kind != SchedulerKind::Rayline) return {};
  return device_sized_job_caps(g, rayline_options(c.horizon / 4, c.rayline_off, c.rayline_on).job_seconds);
}

std::unique_ptr<Scheduler> make_scheduler(const std::string& name, Time horizon, Time aging, bool adaptive_aging) {
  const std::optional<SchedulerKind> kind = scheduler_kind(name);
  if (!kind) throw InputError("scheduler", "", "unknown scheduler '" + name + "' (" + scheduler_names() + ")");
  return make_scheduler(SchedulerChoice{*kind, horizon, aging, adaptive_aging});
}

}  // namespace rayline
