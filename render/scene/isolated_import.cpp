#include "render/scene/isolated_import.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "common/error.hpp"

// Present only in sanitizer builds (compiler-rt's common interface).
extern "C" void __sanitizer_set_death_callback(void (*callback)()) __attribute__((weak));

namespace rayline::scene {
namespace {

static_assert(std::is_trivially_copyable_v<Triangle> && std::is_trivially_copyable_v<ImportStats>);

// Child -> parent: a Frame, then `bytes` bytes of payload.
enum class FrameKind : std::uint32_t { batch = 1, done = 2, input_error = 3, other_error = 4 };
struct Frame {
  FrameKind kind;
  std::uint32_t field_bytes;  // input_error: the first field_bytes of the payload are the field
  std::uint64_t bytes;
};

bool write_all(int fd, const void* data, std::size_t n) {
  const auto* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t k = ::write(fd, p, n);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) return false;
    p += k, n -= std::size_t(k);
  }
  return true;
}

// false at the end of the pipe before `n` bytes.
bool read_all(int fd, void* data, std::size_t n) {
  auto* p = static_cast<char*>(data);
  while (n > 0) {
    const ssize_t k = ::read(fd, p, n);
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) return false;
    p += k, n -= std::size_t(k);
  }
  return true;
}

void send(int fd, FrameKind kind, const void* data, std::size_t bytes, std::uint32_t field_bytes = 0) {
  const Frame f{kind, field_bytes, bytes};
  if (!write_all(fd, &f, sizeof f) || !write_all(fd, data, bytes)) ::_exit(3);  // the parent is gone
}

[[noreturn]] void child_main(int fd, const std::string& path, std::uint64_t cpu_seconds,
                             const std::function<ImportStats(const TriangleBatchFn&)>& import) {
  // A crash here is this process's death by its signal, which the parent reports. Crash
  // handlers inherited from the parent are the parent's: a sanitizer's report, and in a
  // fuzzing build libFuzzer's, which would save the parent's input as a crash of its own.
  if (__sanitizer_set_death_callback) __sanitizer_set_death_callback(nullptr);
  for (const int sig : {SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT, SIGTRAP}) ::signal(sig, SIG_DFL);
  const rlimit no_core{0, 0};
  ::setrlimit(RLIMIT_CORE, &no_core);
  if (cpu_seconds > 0) {
    const rlimit cpu{rlim_t(cpu_seconds), rlim_t(cpu_seconds + 5)};  // SIGXCPU, then SIGKILL
    ::setrlimit(RLIMIT_CPU, &cpu);
  }
  try {
    const ImportStats st =
        import([fd](std::span<const Triangle> batch) { send(fd, FrameKind::batch, batch.data(), batch.size_bytes()); });
    send(fd, FrameKind::done, &st, sizeof st);
  } catch (const InputError& e) {
    // The message without the "FILE: FIELD: " the parent's InputError puts back.
    std::string what = e.what();
    const std::string prefix = InputError(path, e.field(), "").what();
    if (what.rfind(prefix, 0) == 0) what.erase(0, prefix.size());
    const std::string payload = e.field() + what;
    send(fd, FrameKind::input_error, payload.data(), payload.size(), std::uint32_t(e.field().size()));
  } catch (const std::exception& e) {
    send(fd, FrameKind::other_error, e.what(), std::strlen(e.what()));
  } catch (...) {
    ::_exit(3);
  }
  ::close(fd);
  ::_exit(0);
}

// What became of a child that sent no result.
std::string ending(int status, std::uint64_t cpu_seconds) {
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    const std::string limit = " its CPU-time limit of " + std::to_string(cpu_seconds) +
                              " s (RAYLINE_ASSIMP_CPU_SECONDS sets it)";
    if (sig == SIGXCPU) return "assimp did not finish within" + limit + ": it loops on this file";
    if (sig == SIGKILL) return "assimp was killed (out of memory, or past" + limit + ")";
    const char* name = ::strsignal(sig);
    return "assimp crashed on this file (signal " + std::to_string(sig) + (name ? std::string(": ") + name : "") + ")";
  }
  if (WIFEXITED(status)) return "assimp ended without a result (exit status " + std::to_string(WEXITSTATUS(status)) + ")";
  return "assimp ended without a result";
}

// Reaps the child; kills it first if it is still running (the parent stopped reading).
struct Child {
  pid_t pid = -1;
  int status = 0;
  bool reaped = false;
  int wait() {
    while (!reaped && ::waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
    reaped = true;
    return status;
  }
  ~Child() {
    if (pid > 0 && !reaped) {
      ::kill(pid, SIGKILL);
      wait();
    }
  }
};

struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

std::uint64_t assimp_cpu_seconds(const std::string& path) {
  if (const char* env = std::getenv("RAYLINE_ASSIMP_CPU_SECONDS")) {
    char* end = nullptr;
    const unsigned long long v = std::strtoull(env, &end, 10);
    if (end != env && *end == '\0' && v > 0) return v;
  }
  struct stat st {};
  const std::uint64_t mib = ::stat(path.c_str(), &st) == 0 ? std::uint64_t(st.st_size) >> 20 : 0;
  return 60 + mib;
}

ImportStats import_in_child(const std::string& path, const std::function<ImportStats(const TriangleBatchFn&)>& import,
                            const TriangleBatchFn& fn) {
  const std::uint64_t cpu_seconds = assimp_cpu_seconds(path);
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  Fd in{fds[0]}, out{fds[1]};
  const pid_t parent = ::getpid();
  Child child;
  child.pid = ::fork();
  if (child.pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  if (child.pid == 0) {
    // Dies with the parent; had the parent already ended, this is someone else's child: end.
    if (::prctl(PR_SET_PDEATHSIG, SIGKILL) != 0 || ::getppid() != parent) ::_exit(3);
    ::close(in.fd);
    child_main(out.fd, path, cpu_seconds, import);
  }
  ::close(out.fd);
  out.fd = -1;
  std::vector<Triangle> batch;
  std::string text;
  Frame f{};
  while (read_all(in.fd, &f, sizeof f)) {
    if (f.kind == FrameKind::batch && f.bytes % sizeof(Triangle) == 0) {
      batch.resize(f.bytes / sizeof(Triangle));
      if (!read_all(in.fd, batch.data(), f.bytes)) break;
      fn(std::span<const Triangle>(batch));
      continue;
    }
    if (f.kind == FrameKind::done && f.bytes == sizeof(ImportStats)) {
      ImportStats st;
      if (!read_all(in.fd, &st, sizeof st)) break;
      child.wait();
      return st;
    }
    if ((f.kind == FrameKind::input_error || f.kind == FrameKind::other_error) && f.bytes <= (std::uint64_t(1) << 20) &&
        f.field_bytes <= f.bytes) {
      text.resize(f.bytes);
      if (!read_all(in.fd, text.data(), text.size())) break;
      child.wait();
      if (f.kind == FrameKind::input_error) throw InputError(path, text.substr(0, f.field_bytes), text.substr(f.field_bytes));
      throw std::runtime_error(text);
    }
    ::kill(child.pid, SIGKILL);  // not the protocol: no result from it
    child.wait();
    throw InputError(path, "", "cannot import mesh: the importing process sent a malformed result");
  }
  // The pipe ended without a result: the child has ended, or ends now.
  throw InputError(path, "", "cannot import mesh: " + ending(child.wait(), cpu_seconds));
}

}  // namespace rayline::scene
