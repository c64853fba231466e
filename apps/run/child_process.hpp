// Simulations run one per process: SimGrid's engine is a process-wide singleton, so a
// client sweep and `compare` run each simulation in a forked child (sim/sg_platform.hpp).
#pragma once
#include <functional>
#include <string>

namespace rayline::cli {

// Runs body(fd) in a forked child and returns the child's exit code (kExitFailure if it
// did not exit). What the body writes to `fd` comes back in `output`. An interrupt stops
// the child, and it removes its unfinished outputs (apps/interrupt.hpp). The child never
// outlives this process: it gets SIGKILL the moment the calling thread ends (a SIGKILL of
// the parent, the OOM killer, a crash), so a caller that publishes the children's results
// itself knows that nothing of theirs can appear once it is gone. Call it from a thread
// that lives as long as the process (the main thread): the kernel ties the signal to the
// thread that forked.
int run_in_child(const std::function<int(int fd)>& body, std::string& output);

}  // namespace rayline::cli
