// A Vulkan compute device: headless (no surface, no window system), Vulkan 1.1
// core compute only, so Mesa's lavapipe (CPU) and real GPUs share one code path.
// Vulkan types stay out of this header (pimpl).
#pragma once
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace rayline::gpu {

// One physical device as `rayline devices` lists it.
struct GpuDeviceInfo {
  int index = -1;                // position in vkEnumeratePhysicalDevices
  std::string name;              // VkPhysicalDeviceProperties::deviceName
  std::string type;              // "discrete", "integrated", "virtual", "cpu", "other"
  bool cpu_backed = false;       // VK_PHYSICAL_DEVICE_TYPE_CPU (lavapipe)
  std::uint64_t device_local_bytes = 0;  // largest DEVICE_LOCAL heap
  std::string api_version;       // "1.3.230"
  std::string driver;            // driver name/info where the driver reports it
};

// Every physical device; empty (never throws) when there is no Vulkan loader, no ICD or
// no device, and then `why_none` (if given) says which.
std::vector<GpuDeviceInfo> list_gpu_devices(std::string* why_none = nullptr);

enum class GpuErrorKind : std::uint8_t { NoVulkan, NotFound, OutOfMemory, DeviceLost, Failed };

class GpuError : public std::runtime_error {
 public:
  GpuError(GpuErrorKind kind, const std::string& what) : std::runtime_error(what), kind_(kind) {}
  GpuErrorKind kind() const { return kind_; }

 private:
  GpuErrorKind kind_;
};

// A logical device with one compute queue. Thread-safe: uploads (the RAM->GPU channel's
// thread) and dispatches (the GPU compute device's thread) may be issued concurrently.
class GpuContext {
 public:
  // selector: "auto" = the first non-CPU-backed device (throws NotFound when only CPU-backed
  // ones exist); a decimal index; or a case-insensitive substring of the device name
  // ("llvmpipe", "H100"). Throws GpuError (NoVulkan / NotFound / Failed).
  static std::unique_ptr<GpuContext> open(const std::string& selector);
  ~GpuContext();
  GpuContext(const GpuContext&) = delete;
  GpuContext& operator=(const GpuContext&) = delete;

  const GpuDeviceInfo& info() const;
  std::uint64_t allocated_bytes() const;  // device memory held by blocks and ray buffers now
  bool lost() const;                      // a DeviceLost error happened: every later call throws
  // Added: scratch kept between calls, not in allocated_bytes(): kernel-output buffers (one
  // set per concurrently dispatching thread, grown to the largest ray queue seen), host
  // BVH-build arrays (one set per concurrently uploading thread, ~145 B per triangle of
  // the largest block) and the staging buffer of discrete GPUs (64 MiB at most).
  // release_scratch() frees what no call is using now.
  std::uint64_t scratch_bytes() const;
  void release_scratch();
  // Added: whether uploads and results go through host staging buffers (discrete GPUs;
  // any device with RAYLINE_GPU_STAGING=1 set when it is opened) rather than direct
  // mapping of device memory (lavapipe, integrated GPUs).
  bool uses_staging() const;

  // Test hook: the `after_ops`-th GPU operation from now (block upload, ray upload or
  // dispatch; 1 = the next one) throws GpuError(kind); DeviceLost also marks the context lost.
  void inject_fault(int after_ops, GpuErrorKind kind);

  struct Impl;
  Impl& impl() const { return *impl_; }

 private:
  explicit GpuContext(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace rayline::gpu
