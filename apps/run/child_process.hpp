// Simulations run one per process: SimGrid's engine is a process-wide singleton, so a
// client sweep and `compare` run each simulation in a forked child (sim/sg_platform.hpp).
#pragma once
#include <functional>
#include <string>

namespace rayline::cli {

// Runs body(fd) in a forked child and returns the child's exit code (kExitFailure if it
// did not exit). What the body writes to `fd` comes back in `output`. An interrupt stops
// the child, and it removes its unfinished outputs (apps/interrupt.hpp).
int run_in_child(const std::function<int(int fd)>& body, std::string& output);

}  // namespace rayline::cli
