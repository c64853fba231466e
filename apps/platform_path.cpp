#include "apps/platform_path.hpp"

#include <filesystem>

#include "apps/data_dir.hpp"

namespace rayline::cli {

std::string resolve_platform(const std::string& arg) {
  namespace fs = std::filesystem;
  const std::string name = arg.empty() ? "paper-cluster" : arg;
  if (fs::exists(name)) return name;
  if (name.find('/') != std::string::npos || name.ends_with(".json")) return name;  // let the loader report it
  return find_data_file("platforms", "RAYLINE_PLATFORMS", name + ".json", "--platform", name);
}

}  // namespace rayline::cli
