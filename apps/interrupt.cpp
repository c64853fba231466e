#include "apps/interrupt.hpp"

// How an interrupt ends the process without a race against the threads still writing:
//  1. The waiting thread takes the locks of the output registry and of the child list, so
//     that no thread is in the middle of changing either.
//  2. It stops the children (the same signal) and freezes every other thread of this
//     process: each gets kFreeze, whose handler only waits. A writer stops between two
//     system calls, so a folder is never renamed into place or refilled behind the removal.
//  3. It waits for the children, removes the registered paths and exits.
// From step 2 on a frozen thread may hold any lock (malloc's included), so the rest uses
// system calls only: no allocation, no stdio, no std::filesystem.

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "common/unfinished_output.hpp"

namespace rayline::cli {

namespace {

std::mutex children_mutex;
std::vector<pid_t>& children() {
  static auto* c = new std::vector<pid_t>;  // never destroyed (see unfinished::registry)
  return *c;
}

// The signals handled: SIGINT, SIGTERM and SIGHUP, less any this process was started with
// ignored. `nohup` ignores SIGHUP, and a shell ignores SIGINT for a command it runs in the
// background; a blocked signal is not discarded on Linux even when ignored, so sigwait
// would otherwise take it.
sigset_t handled_set;

void choose_signals() {
  sigemptyset(&handled_set);
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction old {};
    if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;
    sigaddset(&handled_set, sig);
  }
}

const int kFreeze = SIGRTMIN + 3;
std::atomic<int> frozen{0};

void freeze_handler(int) {
  frozen.fetch_add(1);
  for (;;) ::pause();
}

void say(const char* text) {
  const ssize_t n = ::write(2, text, std::strlen(text));
  (void)n;
}

struct LinuxDirent {
  unsigned long long ino;
  long long off;
  unsigned short reclen;
  unsigned char type;
  char name[1];
};

// Calls f(name, type) for every entry of the open folder `fd` but "." and "..".
template <class F>
void for_each_entry(int fd, F&& f) {
  alignas(8) char buf[4096];
  for (;;) {
    const long n = ::syscall(SYS_getdents64, fd, buf, sizeof buf);
    if (n <= 0) return;
    for (long off = 0; off < n;) {
      const auto* d = reinterpret_cast<const LinuxDirent*>(buf + off);
      off += d->reclen;
      if (std::strcmp(d->name, ".") != 0 && std::strcmp(d->name, "..") != 0) f(d->name, d->type);
    }
  }
}

// rm -r of `name` inside the folder `dir_fd`, with system calls only; true if it existed.
bool remove_tree(int dir_fd, const char* name, int depth) {
  if (::unlinkat(dir_fd, name, 0) == 0) return true;
  if (errno == ENOENT) return false;
  if (depth > 64) return false;
  const int fd = ::openat(dir_fd, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return false;
  for (;;) {  // entries removed while listing shift the listing: list again until empty
    bool any = false;
    for_each_entry(fd, [&](const char* child, unsigned char) { any = remove_tree(fd, child, depth + 1) || any; });
    if (!any) break;
    ::lseek(fd, 0, SEEK_SET);
  }
  ::close(fd);
  return ::unlinkat(dir_fd, name, AT_REMOVEDIR) == 0;
}

// Freezes every thread of this process but the caller; returns how many were signalled.
int freeze_other_threads() {
  const pid_t self = static_cast<pid_t>(::syscall(SYS_gettid)), pid = ::getpid();
  static pid_t done[4096];
  int n = 0;
  for (bool found = true; found;) {  // threads started meanwhile show up on a later pass
    found = false;
    const int fd = ::open("/proc/self/task", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) break;
    for_each_entry(fd, [&](const char* name, unsigned char) {
      const auto tid = static_cast<pid_t>(std::atol(name));
      if (tid <= 0 || tid == self || std::find(done, done + n, tid) != done + n || n == 4096) return;
      if (::syscall(SYS_tgkill, pid, tid, kFreeze) == 0) {
        done[n++] = tid;
        found = true;
      }
    });
    ::close(fd);
  }
  return n;
}

[[noreturn]] void on_signal(int sig) {
  unfinished::Registry& r = unfinished::registry();
  r.mutex.lock();  // held until the process ends
  children_mutex.lock();
  for (pid_t k : children()) ::kill(k, sig);
  const int n = freeze_other_threads();
  // Wait until they are in the handler. A thread with every signal blocked (some drivers
  // start theirs so) or inside a long system call is given 0.5 s.
  for (int i = 0; i < 500 && frozen.load() < n; ++i) ::usleep(1000);
  for (pid_t k : children()) ::waitpid(k, nullptr, 0);
  int removed = 0;
  for (const std::string& p : r.paths) removed += remove_tree(AT_FDCWD, p.c_str(), 0) ? 1 : 0;
  say(sig == SIGINT ? "rayline: interrupted (SIGINT)" : sig == SIGTERM ? "rayline: interrupted (SIGTERM)"
                                                                       : "rayline: interrupted (SIGHUP)");
  if (removed > 0) {
    char num[12];
    int k = sizeof num;
    num[--k] = 0;
    for (int v = removed; v > 0 && k > 0; v /= 10) num[--k] = static_cast<char>('0' + v % 10);
    say("; removed ");
    say(num + k);
    say(removed > 1 ? " unfinished outputs" : " unfinished output");
  }
  say("\n");
  ::_exit(128 + sig);
}

void start_waiting() {
  std::thread([] {
    const sigset_t s = handled_set;
    for (;;) {
      int sig = 0;
      if (::sigwait(&s, &sig) == 0) on_signal(sig);
    }
  }).detach();
}

}  // namespace

void install_interrupt_cleanup() {
  choose_signals();
  // A file size limit (ulimit -f) then fails the write with EFBIG, which the run reports and
  // cleans up after as any failed write, instead of SIGXFSZ ending the process mid-write.
  ::signal(SIGXFSZ, SIG_IGN);
  struct sigaction fz {};
  fz.sa_handler = freeze_handler;
  sigemptyset(&fz.sa_mask);
  ::sigaction(kFreeze, &fz, nullptr);
  ::pthread_sigmask(SIG_BLOCK, &handled_set, nullptr);
  start_waiting();
}

void interrupt_cleanup_after_fork() {
  {
    unfinished::Registry& r = unfinished::registry();
    const std::lock_guard<std::mutex> lock(r.mutex);
    r.paths.clear();
  }
  {
    const std::lock_guard<std::mutex> lock(children_mutex);
    children().clear();
  }
  frozen.store(0);
  start_waiting();
}

void add_child(pid_t pid) {
  if (pid <= 0) return;  // not a child: kill(-1, sig) or kill(0, sig) would reach other processes
  const std::lock_guard<std::mutex> lock(children_mutex);
  children().push_back(pid);
}

void remove_child(pid_t pid) {
  const std::lock_guard<std::mutex> lock(children_mutex);
  auto& c = children();
  c.erase(std::remove(c.begin(), c.end(), pid), c.end());
}

}  // namespace rayline::cli
