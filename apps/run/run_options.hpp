// The run facade's typed options (apps/run/): every subcommand that runs a schedule
// (plan, simulate, compare, render) turns its text flags into these through the functions
// here and in apps/cli_common.hpp (durations, sizes), so a flag means the same and fails
// with the same message everywhere. Each throws InputError naming the flag; the names of
// schedulers come from the factory (sched/policy/scheduler_factory.hpp) and nowhere else.
#pragma once
#include <string>

#include "apps/cli_common.hpp"
#include "sched/core/types.hpp"
#include "sched/policy/scheduler_factory.hpp"

namespace rayline::cli {

// A duration flag in seconds: duration_flag (apps/cli_common.hpp, a unit required), under
// the name the run facade's subcommands call it by.
inline Time seconds_flag(const std::string& flag, const std::string& text) { return duration_flag(flag, text); }

// A scheduler name. `known` prefixes the list of names in the message ("known: " or "").
SchedulerKind scheduler_flag(const std::string& flag, const std::string& name, const std::string& known = "known: ");

// --aging (GMB, Sec. 4.3): "auto" (GMB's default, 5k and at least 1 s), "adaptive" (auto,
// and at least twice the queue's median wait), "off", or a duration >= 0.
struct AgingSetting {
  Time aging = -1;  // GmbOptions::aging
  bool adaptive = false;
};
AgingSetting parse_aging(const std::string& text, const std::string& flag);

// The scheduler flags as the factory takes them: --scheduler (checked), the horizon k in
// seconds (> 0, Sec. 4.2) and --aging.
SchedulerChoice scheduler_choice(const std::string& name, Time horizon, const AgingSetting& aging);

// --rayline-off: Rayline's rules to switch off (SchedulerChoice::rayline_off), for an
// ablation; only with the rayline scheduler (given with another `kind`: InputError).
unsigned rayline_rules_flag(const std::string& list, SchedulerKind kind, const std::string& flag = "--rayline-off");

}  // namespace rayline::cli
