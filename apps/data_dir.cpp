#include "apps/data_dir.hpp"

#include <cstdlib>
#include <filesystem>
#include <system_error>

#include "common/error.hpp"

namespace rayline::cli {

namespace fs = std::filesystem;

namespace {
// The folder of the running executable (empty when /proc/self/exe cannot be read).
fs::path executable_dir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : exe.parent_path();
}
}  // namespace

std::vector<std::string> data_dirs(const std::string& kind, const char* env_var) {
  if (const char* env = std::getenv(env_var); env && *env) return {env};
  std::vector<std::string> dirs;
  if (const fs::path bin = executable_dir(); !bin.empty())
    dirs.push_back((bin / RAYLINE_DATA_FROM_BIN / kind).lexically_normal().string());
  dirs.push_back((fs::path(RAYLINE_SOURCE_DIR) / kind).string());
  return dirs;
}

std::string find_data_file(const std::string& kind, const char* env_var, const std::string& file,
                           const std::string& flag, const std::string& name) {
  const std::vector<std::string> dirs = data_dirs(kind, env_var);
  std::string searched;
  for (const std::string& dir : dirs) {
    const fs::path p = fs::path(dir) / file;
    std::error_code ec;
    if (fs::is_regular_file(p, ec)) return p.string();
    searched += (searched.empty() ? "" : ", ") + dir;
  }
  throw InputError(flag, "", "'" + name + "' is neither a file nor a built-in name: no " + file + " in " + searched +
                                 " (set $" + env_var + " to the folder that holds it)");
}

}  // namespace rayline::cli
