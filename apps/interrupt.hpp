// SIGINT, SIGTERM and SIGHUP end a run without litter: the unfinished outputs registered
// in common/unfinished_output.hpp are removed, the results of earlier runs are untouched
// (they are replaced only by a rename once complete), and the exit code is 128 + signal.
#pragma once
#include <sys/types.h>

namespace rayline::cli {

// Call first in main(), before any thread exists: blocks the three signals in every thread
// and waits for them on one thread of its own (sigwait), which removes the registered
// outputs, stops the registered child processes and ends the process. SIGXFSZ is ignored,
// so that a write past a file size limit fails (EFBIG) as a write to a full disk does.
void install_interrupt_cleanup();

// In a child of fork() that runs a command (compare, client sweeps): forget the parent's
// registrations and wait for the signals on a thread of this process.
void interrupt_cleanup_after_fork();

// The parent's children, which the handler stops (with the same signal) and waits for, so
// that each removes its own unfinished outputs first.
void add_child(pid_t pid);
void remove_child(pid_t pid);

}  // namespace rayline::cli
