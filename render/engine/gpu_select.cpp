#include "render/engine/gpu_select.hpp"

#include "common/error.hpp"

namespace rayline::engine {

std::unique_ptr<gpu::GpuContext> select_gpu(const std::string& selector, std::string& status) {
  const std::string sel = selector.empty() ? "auto" : selector;
  if (sel == "none") {
    status = "none: --gpu none";
    return nullptr;
  }
  try {
    auto ctx = gpu::GpuContext::open(sel);
    status = "used";
    return ctx;
  } catch (const gpu::GpuError& e) {
    if (sel == "auto") {
      status = std::string("none: ") + e.what();
      return nullptr;
    }
    // The device layer's message names the selector and lists the devices.
    throw InputError("--gpu", "", std::string(e.what()) + " (see `rayline devices`; --gpu none renders on the CPU)");
  }
}

Bytes gpu_memory_budget(const gpu::GpuDeviceInfo& info, Bytes requested) {
  const Bytes local = info.device_local_bytes;
  Bytes budget = requested > 0 ? requested : local / 2;
  if (budget == 0) budget = Bytes(1) << 30;
  if (local > 0 && budget > local)
    throw InputError("--gpu-memory-budget", "",
                     std::to_string(budget) + " bytes is more than the " + std::to_string(local) +
                         " bytes of local memory of '" + info.name + "'");
  return budget;
}

}  // namespace rayline::engine
