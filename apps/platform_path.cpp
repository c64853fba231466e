#include "apps/platform_path.hpp"

#include <cstdlib>
#include <filesystem>

namespace rayline::cli {

std::string resolve_platform(const std::string& arg) {
  namespace fs = std::filesystem;
  const std::string name = arg.empty() ? "paper-cluster" : arg;
  if (fs::exists(name)) return name;
  if (name.find('/') != std::string::npos || name.ends_with(".json")) return name;  // let the loader report it
  const char* env = std::getenv("RAYLINE_PLATFORMS");
  const fs::path dir = env ? fs::path(env) : fs::path(RAYLINE_PLATFORM_DIR);
  return (dir / (name + ".json")).string();
}

}  // namespace rayline::cli
