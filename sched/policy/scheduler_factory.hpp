// The schedulers by name, for every engine (sim and render) and the command line:
// "gmb" (the paper, Sec. 4.2-4.3), "gmb-ca" (completion-aware GMB), "budge" (Budge 2009),
// "loadanyonce" (Navrátil 2014). Unknown names are an InputError naming the flag.
// `aging` (GMB only, Sec. 4.3): seconds a job may wait before it jumps the queue; < 0: GMB's
// default (5k, at least 1 s); kNever: off. `adaptive_aging`: GmbOptions::adaptive_aging.
#pragma once
#include <memory>
#include <string>

#include "sched/policy/scheduler.hpp"

namespace rayline {

std::unique_ptr<Scheduler> make_scheduler(const std::string& name, Time horizon, Time aging = -1,
                                          bool adaptive_aging = false);

}  // namespace rayline
