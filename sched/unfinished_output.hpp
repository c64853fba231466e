// Outputs still being written: OUT.partial.<pid>/, FILE.tmp.<pid>, a render's temporary
// partition (DESIGN.md, "Bad input": outputs are written to a temporary name and renamed
// when complete). A run stopped by SIGINT, SIGTERM or SIGHUP left them behind, hundreds of
// MB for a partition or a generated mesh; the command line's interrupt handler
// (apps/interrupt.hpp) removes every path registered here before the process ends.
//
// Header-only so that every library (scene, partition, image, sim) can register without a
// link dependency; the registry is one per process (an inline function's static).
#pragma once
#include <algorithm>
#include <mutex>
#include <string>
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

}  // namespace rayline::unfinished
