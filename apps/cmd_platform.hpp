// `rayline platform check FILE`: validate and summarise a platform (DCG) file.
#pragma once
#include <string>

namespace rayline::cli {

struct PlatformCheckOptions {
  std::string file;
  std::string block_size = "210MB";  // reference block for the shortest-fetch-time table
  bool json = false;                 // machine-readable summary on stdout
};
int run_platform_check(const PlatformCheckOptions& opt);

}  // namespace rayline::cli
