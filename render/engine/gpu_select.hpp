// Choosing the Vulkan device of `--gpu` and its memory budget, shared by
// `rayline render`, `rayline calibrate` and `rayline devices`.
#pragma once
#include <memory>
#include <string>

#include "render/vulkan/vulkan_device.hpp"
#include "sched/core/types.hpp"

namespace rayline::engine {

// "none" -> nullptr. "auto" -> the first non-CPU-backed device, or nullptr when there is
// none (no loader, no driver, only lavapipe); `status` says which. An index or a name
// substring must match a device: InputError("--gpu", ...) listing the devices otherwise.
std::unique_ptr<gpu::GpuContext> select_gpu(const std::string& selector, std::string& status);

// The GPU memory device's capacity: `requested` (0 = half of the device's local memory),
// checked against the device. InputError("--gpu-memory-budget", ...) when it cannot work.
Bytes gpu_memory_budget(const gpu::GpuDeviceInfo& info, Bytes requested);

}  // namespace rayline::engine
