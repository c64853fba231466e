// `rayline devices`: every Vulkan device this machine has (lavapipe flagged as
// CPU-backed), and the device connectivity graph the renderer would drive with the same
// options: compute and memory devices, channels, and the timing model in use.
#pragma once
#include <string>

namespace rayline::cli {

struct DevicesCliOptions {
  std::string platform = "auto";
  int threads = 0;
  std::string gpu = "auto";
  std::string memory_budget, gpu_memory_budget;
  bool json = false;
};
int run_devices(const DevicesCliOptions& opt);

}  // namespace rayline::cli
