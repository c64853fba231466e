#include "sched/policy/scheduler_factory.hpp"

#include "sched/policy/budge.hpp"
#include "common/error.hpp"
#include "sched/policy/gmb/gmb_scheduler.hpp"
#include "sched/policy/load_any_once.hpp"

namespace rayline {

std::unique_ptr<Scheduler> make_scheduler(const std::string& name, Time horizon, Time aging, bool adaptive_aging) {
  if (name == "gmb" || name == "gmb-ca")
    return std::make_unique<GmbScheduler>(
        GmbOptions{.horizon = horizon, .aging = aging, .adaptive_aging = adaptive_aging, .completion_aware = name == "gmb-ca"});
  if (name == "budge") return std::make_unique<BudgeScheduler>();
  if (name == "loadanyonce") return std::make_unique<LoadAnyOnceScheduler>();
  throw InputError("--scheduler", "", "unknown scheduler '" + name + "' (gmb, gmb-ca, budge, loadanyonce)");
}

}  // namespace rayline
