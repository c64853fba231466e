#include "render/store/temp_partition.hpp"

#include <chrono>
#include <filesystem>
#include <system_error>

#include "common/unfinished_output.hpp"

namespace rayline::engine {

TempPartition::TempPartition() {
  const std::string stem = (std::filesystem::temp_directory_path() / "rayline-blocks-").string();
  unfinished::sweep_stale(stem, true);
  path_ = unfinished::temp_name(stem + std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()),
                                "partial");
  unfinished::add(path_);
}

TempPartition::~TempPartition() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
  unfinished::remove(path_);
}

}  // namespace rayline::engine
