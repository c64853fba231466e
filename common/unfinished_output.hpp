// Outputs still being written: OUT.partial.<pid>@<host>/, FILE.tmp.<pid>@<host>, a render's
// temporary partition (docs/architecture.md, "Bad input": outputs are written to a temporary name and
// renamed when complete). A run stopped by SIGINT, SIGTERM or SIGHUP left them behind,
// hundreds of MB for a partition or a generated mesh; the command line's interrupt handler
// (apps/interrupt.hpp) removes every path registered here before the process ends.
//
// A run that no handler could clean up after (SIGKILL, the OOM killer, a crash, a power cut)
// still leaves them. Their names carry the writer's pid and host, so the next run writing the
// same output, on the same host, removes those whose process no longer exists (sweep_stale).
// A run on another host sharing the folder, or one whose pid is alive, is never touched.
//
// Header-only so that every library (scene, partition, image, sim) can register without a
// link dependency; the registry is one per process (an inline function's static).
#pragma once
#include <signal.h>  // kill
#include <unistd.h>  // getpid, gethostname

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace rayline::unfinished {

struct Registry {
  std::mutex mutex;
  std::vector<std::string> paths;  // removed (recursively) on interrupt
};

// Never destroyed: the interrupt thread may still use it while the process exits.
inline Registry& registry() {
  static Registry* r = new Registry;
  return *r;
}

inline void add(const std::string& path) {
  Registry& r = registry();
  const std::lock_guard<std::mutex> lock(r.mutex);
  r.paths.push_back(path);
}

inline void remove(const std::string& path) {
  Registry& r = registry();
  const std::lock_guard<std::mutex> lock(r.mutex);
  const auto it = std::find(r.paths.rbegin(), r.paths.rend(), path);
  if (it != r.paths.rend()) r.paths.erase(std::next(it).base());
}

// Registered for its lifetime: construct before creating the path, and let it go out of
// scope once the path is renamed into place or removed.
class Guard {
 public:
  explicit Guard(std::string path) : path_(std::move(path)) { add(path_); }
  ~Guard() { remove(path_); }
  Guard(const Guard&) = delete;
  Guard& operator=(const Guard&) = delete;

 private:
  std::string path_;
};

// "<pid>@<host>": who writes a temporary name (the host as gethostname gives it, any
// character outside [A-Za-z0-9._-] replaced by '_').
inline std::string owner_tag() {
  std::array<char, 256> h{};
  std::string host = ::gethostname(h.data(), h.size() - 1) == 0 && h[0] ? h.data() : "localhost";
  for (char& c : host)
    if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-'))
      c = '_';
  return std::to_string(::getpid()) + "@" + host;
}

// The temporary name of `target` while this process writes it: TARGET.<kind>.<pid>@<host>.
// kind: "partial" (a folder or an image), "tmp" (a file), "old" (a replaced folder set
// aside), "tmp-faces" (a mesh writer's second file).
inline std::string temp_name(const std::string& target, std::string_view kind) {
  return target + "." + std::string(kind) + "." + owner_tag();
}

// True when `tag` ("<pid>@<host>") names a process of this host that has ended. Another
// host's tag, a malformed one, this process and any live pid (even one reused since) are
// not gone: a sweep would rather leave a leftover than remove a live run's output.
inline bool owner_gone(std::string_view tag) {
  const std::size_t at = tag.find('@');
  if (at == 0 || at == std::string_view::npos || at > 9) return false;
  long pid = 0;
  for (char c : tag.substr(0, at)) {
    if (c < '0' || c > '9') return false;
    pid = pid * 10 + (c - '0');
  }
  const std::string mine = owner_tag();
  if (tag.substr(at) != std::string_view(mine).substr(mine.find('@'))) return false;  // another host
  if (pid <= 1 || pid == ::getpid()) return false;
  return ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
}

// Removes what ended runs on this host left of `target`: the entries beside it named
// TARGET.<kind>.<tag> (kinds of temp_name) with owner_gone(tag). An `old` folder is the
// target's earlier results set aside by publish_folder's two-rename path: it is put back
// when the target is missing, and removed otherwise. With `prefix` set, every entry whose
// stem starts with the target's name counts (a render's /tmp/rayline-blocks-<ns> folders).
// Each removal is reported on stderr. Best effort: errors are ignored.
inline void sweep_stale(const std::string& target, bool prefix = false) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path t(target);
  const fs::path dir = t.has_parent_path() ? t.parent_path() : fs::path(".");
  const std::string stem = t.filename().string();
  if (stem.empty()) return;
  std::vector<std::pair<fs::path, bool>> stale;  // (entry, is an `old` folder)
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const std::size_t at = name.rfind('@');
    if (at == std::string::npos || !name.starts_with(stem)) continue;
    const std::size_t dot = name.rfind('.', at);  // before the pid
    if (dot == std::string::npos || dot == 0) continue;
    const std::size_t kdot = name.rfind('.', dot - 1);  // before the kind
    if (kdot == std::string::npos || kdot < stem.size() || (!prefix && kdot != stem.size())) continue;
    const std::string_view kind = std::string_view(name).substr(kdot + 1, dot - kdot - 1);
    if (kind != "partial" && kind != "tmp" && kind != "old" && kind != "tmp-faces") continue;
    if (owner_gone(std::string_view(name).substr(dot + 1))) stale.emplace_back(it->path(), kind == "old");
  }
  for (const auto& [p, old] : stale) {
    std::error_code e;
    if (old && !prefix && !fs::exists(t, e)) {
      fs::rename(p, t, e);
      if (!e) std::fprintf(stderr, "rayline: put back %s, set aside by a run that ended before it finished\n", target.c_str());
      continue;
    }
    if (fs::remove_all(p, e) != static_cast<std::uintmax_t>(-1) && !e)
      std::fprintf(stderr, "rayline: removed %s, left by a run that ended before it finished\n", p.string().c_str());
  }
}

// sweep_stale(target), then temp_name(target, kind): the name to write `target` under.
inline std::string fresh_temp_name(const std::string& target, std::string_view kind) {
  sweep_stale(target);
  return temp_name(target, kind);
}

}  // namespace rayline::unfinished
