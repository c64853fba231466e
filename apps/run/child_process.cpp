#include "apps/run/child_process.hpp"

#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <stdexcept>

#include "apps/cli_common.hpp"
#include "apps/interrupt.hpp"

namespace rayline::cli {

int run_in_child(const std::function<int(int fd)>& body, std::string& output) {
  int fds[2];
  if (::pipe(fds) != 0) throw std::runtime_error("pipe failed");
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("fork failed");
  if (pid == 0) {
    // Dies with the parent. Had the parent already ended before the request took effect,
    // this process is someone else's child now: end at once.
    if (::prctl(PR_SET_PDEATHSIG, SIGKILL) != 0 || ::getppid() != parent) ::_exit(kExitFailure);
    interrupt_cleanup_after_fork();
    ::close(fds[0]);
    const int rc = body(fds[1]);
    ::close(fds[1]);
    std::fflush(nullptr);
    ::_exit(rc);
  }
  add_child(pid);  // an interrupt stops it, and it removes its unfinished outputs
  ::close(fds[1]);
  char buf[512];
  for (ssize_t k; (k = ::read(fds[0], buf, sizeof buf)) > 0;) output.append(buf, static_cast<std::size_t>(k));
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  remove_child(pid);
  return WIFEXITED(status) ? WEXITSTATUS(status) : kExitFailure;
}

}  // namespace rayline::cli
