#include "apps/run/run_options.hpp"

#include <cmath>

#include "apps/cli_common.hpp"
#include "common/error.hpp"
#include "sched/policy/rayline/rayline_scheduler.hpp"

namespace rayline::cli {

SchedulerKind scheduler_flag(const std::string& flag, const std::string& name, const std::string& known) {
  if (const std::optional<SchedulerKind> kind = scheduler_kind(name)) return *kind;
  throw InputError(flag, "", "unknown scheduler '" + name + "' (" + known + scheduler_names() + ")");
}

AgingSetting parse_aging(const std::string& text, const std::string& flag) {
  AgingSetting a;
  if (text == "auto") return a;
  if (text == "adaptive") {
    a.adaptive = true;
    return a;
  }
  if (text == "off") {
    a.aging = kNever;
    return a;
  }
  try {
    a.aging = duration_flag(flag, text);
  } catch (const InputError& e) {
    throw InputError(flag, "", "auto, adaptive, off or a duration: " + std::string(e.what()).substr(flag.size() + 2));
  }
  if (!(a.aging >= 0)) throw InputError(flag, "", "must be >= 0, auto, adaptive or off");
  return a;
}

SchedulerChoice scheduler_choice(const std::string& name, Time horizon, const AgingSetting& aging) {
  SchedulerChoice c;
  c.kind = scheduler_flag("--scheduler", name);
  if (!(horizon > 0)) throw InputError("--horizon", "", "must be > 0");
  if (std::isnan(aging.aging)) throw InputError("--aging", "", "must be a duration, auto, adaptive or off");
  c.horizon = horizon;
  c.aging = aging.aging;
  c.adaptive_aging = aging.adaptive;
  return c;
}

unsigned rayline_rules_flag(const std::string& list, SchedulerKind kind, const std::string& flag) {
  if (list.empty()) return 0;
  const std::optional<unsigned> mask = rayline_rules_off(list);
  if (!mask) {
    std::string names;
    for (std::string_view n : kRaylineRuleNames) (names.empty() ? names : names.append(", ")).append(n);
    throw InputError(flag, "", "unknown rule in '" + list + "' (rules: " + names + ")");
  }
  if (kind != SchedulerKind::Rayline) throw InputError(flag, "", "applies to --scheduler rayline only");
  return *mask;
}

}  // namespace rayline::cli
