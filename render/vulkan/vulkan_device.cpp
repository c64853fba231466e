// The Vulkan instance, device listing and selection, the logical device with its one
// compute queue, and GpuContext (vulkan_device.hpp). Vulkan 1.1 core, no layers, no
// extensions, no surface: lavapipe (Mesa's CPU driver, CI) and real GPUs share one path.
#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <exception>

#include "render/vulkan/vulkan_internal.hpp"

namespace rayline::gpu {
namespace detail {

std::string vk_result_name(VkResult r) {
  switch (r) {
#define RL_CASE(x) \
  case x:          \
    return #x;
    RL_CASE(VK_SUCCESS)
    RL_CASE(VK_NOT_READY)
    RL_CASE(VK_TIMEOUT)
    RL_CASE(VK_INCOMPLETE)
    RL_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
    RL_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
    RL_CASE(VK_ERROR_INITIALIZATION_FAILED)
    RL_CASE(VK_ERROR_DEVICE_LOST)
    RL_CASE(VK_ERROR_MEMORY_MAP_FAILED)
    RL_CASE(VK_ERROR_LAYER_NOT_PRESENT)
    RL_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
    RL_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
    RL_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
    RL_CASE(VK_ERROR_TOO_MANY_OBJECTS)
    RL_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
    RL_CASE(VK_ERROR_FRAGMENTED_POOL)
    RL_CASE(VK_ERROR_UNKNOWN)
    RL_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
#undef RL_CASE
    default:
      return "VkResult(" + std::to_string(static_cast<int>(r)) + ")";
  }
}

GpuErrorKind kind_of(VkResult r) {
  switch (r) {
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
    case VK_ERROR_OUT_OF_HOST_MEMORY:
      return GpuErrorKind::OutOfMemory;
    case VK_ERROR_DEVICE_LOST:
      return GpuErrorKind::DeviceLost;
    case VK_ERROR_INCOMPATIBLE_DRIVER:
    case VK_ERROR_INITIALIZATION_FAILED:
      return GpuErrorKind::NoVulkan;
    default:
      return GpuErrorKind::Failed;
  }
}

void throw_vk(const char* call, VkResult r, Core* core) {
  const GpuErrorKind k = kind_of(r);
  if (k == GpuErrorKind::DeviceLost && core) core->lost = true;
  throw GpuError(k, std::string("Vulkan: ") + call + " failed: " + vk_result_name(r));
}

namespace {

// A 1.1 instance with no layers and no extensions (headless compute needs none).
VkResult create_instance(VkInstance* out) {
  VkApplicationInfo app{};
  app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
  app.pApplicationName = "rayline";
  app.applicationVersion = 1;
  app.pEngineName = "rayline-gpu";
  app.engineVersion = 1;
  app.apiVersion = VK_API_VERSION_1_1;
  VkInstanceCreateInfo ci{};
  ci.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
  ci.pApplicationInfo = &app;
  return vkCreateInstance(&ci, nullptr, out);
}

std::string version_string(std::uint32_t v) {
  return std::to_string(VK_API_VERSION_MAJOR(v)) + "." + std::to_string(VK_API_VERSION_MINOR(v)) + "." +
         std::to_string(VK_API_VERSION_PATCH(v));
}

bool has_device_extension(VkPhysicalDevice pd, const char* name) {
  std::uint32_t n = 0;
  if (vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, nullptr) != VK_SUCCESS) return false;
  std::vector<VkExtensionProperties> ext(n);
  if (vkEnumerateDeviceExtensionProperties(pd, nullptr, &n, ext.data()) != VK_SUCCESS) return false;
  for (const auto& e : ext)
    if (std::strcmp(e.extensionName, name) == 0) return true;
  return false;
}

GpuDeviceInfo describe(VkPhysicalDevice pd, int index) {
  VkPhysicalDeviceProperties p{};
  vkGetPhysicalDeviceProperties(pd, &p);
  VkPhysicalDeviceMemoryProperties m{};
  vkGetPhysicalDeviceMemoryProperties(pd, &m);
  GpuDeviceInfo info;
  info.index = index;
  info.name = p.deviceName;
  switch (p.deviceType) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: info.type = "discrete"; break;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: info.type = "integrated"; break;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: info.type = "virtual"; break;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: info.type = "cpu"; break;
    default: info.type = "other"; break;
  }
  info.cpu_backed = p.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
  for (std::uint32_t h = 0; h < m.memoryHeapCount; ++h)
    if (m.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT)
      info.device_local_bytes = std::max<std::uint64_t>(info.device_local_bytes, m.memoryHeaps[h].size);
  info.api_version = version_string(p.apiVersion);
  // The driver's own name ("llvmpipe", "NVIDIA") is VK_KHR_driver_properties: a
  // physical-device query, usable on a 1.1 instance where the device lists it.
  if (has_device_extension(pd, VK_KHR_DRIVER_PROPERTIES_EXTENSION_NAME)) {
    VkPhysicalDeviceDriverPropertiesKHR drv{};
    drv.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES_KHR;
    VkPhysicalDeviceProperties2 p2{};
    p2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
    p2.pNext = &drv;
    vkGetPhysicalDeviceProperties2(pd, &p2);
    info.driver = drv.driverName;
    if (drv.driverInfo[0]) info.driver += std::string(" (") + drv.driverInfo + ")";
  } else {
    info.driver = "driver version " + std::to_string(p.driverVersion);
  }
  return info;
}

// Every physical device of `instance`, or a reason why there is none.
std::vector<VkPhysicalDevice> physical_devices(VkInstance instance, std::string* why) {
  std::uint32_t n = 0;
  VkResult r = vkEnumeratePhysicalDevices(instance, &n, nullptr);
  std::vector<VkPhysicalDevice> pds(n);
  if (r == VK_SUCCESS && n) r = vkEnumeratePhysicalDevices(instance, &n, pds.data());
  if (r != VK_SUCCESS && r != VK_INCOMPLETE) {
    if (why) *why = "vkEnumeratePhysicalDevices failed: " + vk_result_name(r);
    return {};
  }
  pds.resize(n);
  if (pds.empty() && why) *why = "the Vulkan loader found no physical device (no driver/ICD installed?)";
  return pds;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string device_list(const std::vector<GpuDeviceInfo>& infos) {
  std::string s;
  for (const auto& i : infos) {
    if (!s.empty()) s += "; ";
    s += std::to_string(i.index) + ": " + i.name + " [" + i.type + "]";
  }
  return s.empty() ? "none" : s;
}

// The device `selector` names (vulkan_device.hpp: "auto", an index, a name substring).
int select_device(const std::vector<GpuDeviceInfo>& infos, const std::string& selector) {
  const std::string sel = selector.empty() ? "auto" : selector;
  if (lower(sel) == "auto") {
    for (const auto& i : infos)
      if (!i.cpu_backed) return i.index;
    throw GpuError(GpuErrorKind::NotFound,
                   "GPU: selector 'auto' found no GPU, only CPU-backed Vulkan devices (" + device_list(infos) +
                       "); name one explicitly, e.g. 'llvmpipe'");
  }
  if (std::all_of(sel.begin(), sel.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
    const long idx = sel.size() > 9 ? -1 : std::stol(sel);
    if (idx >= 0 && idx < static_cast<long>(infos.size())) return static_cast<int>(idx);
    throw GpuError(GpuErrorKind::NotFound, "GPU: no Vulkan device with index " + sel + " (devices: " + device_list(infos) + ")");
  }
  const std::string want = lower(sel);
  for (const auto& i : infos)
    if (lower(i.name).find(want) != std::string::npos) return i.index;
  throw GpuError(GpuErrorKind::NotFound,
                 "GPU: no Vulkan device matches '" + sel + "' (devices: " + device_list(infos) + ")");
}

// Index of a memory type with all of `required` (and as many `preferred` as possible).
std::uint32_t find_type(const VkPhysicalDeviceMemoryProperties& m, VkMemoryPropertyFlags required,
                        VkMemoryPropertyFlags preferred, VkMemoryPropertyFlags avoided) {
  std::uint32_t best = UINT32_MAX;
  int best_score = -1000;
  for (std::uint32_t t = 0; t < m.memoryTypeCount; ++t) {
    const VkMemoryPropertyFlags f = m.memoryTypes[t].propertyFlags;
    if ((f & required) != required) continue;
    int score = 0;
    for (VkMemoryPropertyFlags bit = 1; bit; bit <<= 1) {
      if ((preferred & bit) && (f & bit)) score += 2;
      if ((avoided & bit) && (f & bit)) score -= 1;
    }
    if (score > best_score) best = t, best_score = score;
  }
  return best;
}

void destroy_slot(Core& c, Slot& s) {
  c.scratch_bytes -= s.out_device.size + s.out_host.size;
  s.out_device.reset();
  s.out_host.reset();
  if (s.queries) vkDestroyQueryPool(c.device, s.queries, nullptr);
  if (s.descriptors) vkDestroyDescriptorPool(c.device, s.descriptors, nullptr);
  if (s.fence) vkDestroyFence(c.device, s.fence, nullptr);
  if (s.pool) vkDestroyCommandPool(c.device, s.pool, nullptr);  // frees its command buffer
  s = Slot{};
}

const char* kind_name(GpuErrorKind k) {
  switch (k) {
    case GpuErrorKind::NoVulkan: return "NoVulkan";
    case GpuErrorKind::NotFound: return "NotFound";
    case GpuErrorKind::OutOfMemory: return "OutOfMemory";
    case GpuErrorKind::DeviceLost: return "DeviceLost";
    default: return "Failed";
  }
}

}  // namespace

Core::~Core() {
  if (device) {
    vkDeviceWaitIdle(device);  // nothing may still run on what we free (errors ignored)
    for (auto& s : free_slots) destroy_slot(*this, *s);
    free_slots.clear();
    staging.reset();
    dummy.reset();
    destroy_pipelines(*this);
    vkDestroyDevice(device, nullptr);
  }
  if (instance) vkDestroyInstance(instance, nullptr);
}

void Core::begin_op(const char* what) {
  if (lost) throw GpuError(GpuErrorKind::DeviceLost, std::string("GPU: the device was lost; ") + what + " refused");
  std::lock_guard lk(fault_mutex);
  if (fault_countdown > 0 && --fault_countdown == 0) {
    if (fault_kind == GpuErrorKind::DeviceLost) lost = true;
    throw GpuError(fault_kind, std::string("GPU: injected fault (") + kind_name(fault_kind) + ") in " + what);
  }
}

std::unique_ptr<Slot> Core::acquire_slot() {
  {
    std::lock_guard lk(slot_mutex);
    if (!free_slots.empty()) {
      auto s = std::move(free_slots.back());
      free_slots.pop_back();
      return s;
    }
  }
  auto s = std::make_unique<Slot>();
  try {
    VkCommandPoolCreateInfo pi{};
    pi.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    pi.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
    pi.queueFamilyIndex = family;
    check(vkCreateCommandPool(device, &pi, nullptr, &s->pool), "vkCreateCommandPool", this);
    VkCommandBufferAllocateInfo ai{};
    ai.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    ai.commandPool = s->pool;
    ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ai.commandBufferCount = 1;
    check(vkAllocateCommandBuffers(device, &ai, &s->cmd), "vkAllocateCommandBuffers", this);
    VkFenceCreateInfo fi{};
    fi.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    check(vkCreateFence(device, &fi, nullptr, &s->fence), "vkCreateFence", this);
    if (timestamps) {
      VkQueryPoolCreateInfo qi{};
      qi.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
      qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
      qi.queryCount = 3;  // dispatch start, dispatch end, copy end
      check(vkCreateQueryPool(device, &qi, nullptr, &s->queries), "vkCreateQueryPool", this);
    }
  } catch (...) {
    destroy_slot(*this, *s);
    throw;
  }
  return s;
}

void Core::release_slot(std::unique_ptr<Slot> s) {
  if (lost) {  // its fence or command buffer may be in any state: drop it
    destroy_slot(*this, *s);
    return;
  }
  std::lock_guard lk(slot_mutex);
  free_slots.push_back(std::move(s));
}

std::unique_ptr<BuildCache> Core::acquire_build() {
  {
    std::lock_guard lk(build_mutex);
    if (!free_builds.empty()) {
      auto b = std::move(free_builds.back());
      free_builds.pop_back();
      build_bytes -= b->bytes();
      return b;
    }
  }
  return std::make_unique<BuildCache>();
}

void Core::release_build(std::unique_ptr<BuildCache> b) {
  std::lock_guard lk(build_mutex);
  build_bytes += b->bytes();
  free_builds.push_back(std::move(b));
}

void Core::release_scratch() {
  {
    std::lock_guard lk(slot_mutex);
    for (auto& s : free_slots) {
      scratch_bytes -= s->out_device.size + s->out_host.size;
      s->out_device.reset();
      s->out_host.reset();
    }
  }
  {
    std::lock_guard lk(build_mutex);
    free_builds.clear();
    build_bytes = 0;
  }
  std::lock_guard lk(staging_mutex);
  scratch_bytes -= staging.size;
  staging.reset();
}

void Core::submit_and_wait(Slot& s) {
  check(vkEndCommandBuffer(s.cmd), "vkEndCommandBuffer", this);
  VkSubmitInfo si{};
  si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
  si.commandBufferCount = 1;
  si.pCommandBuffers = &s.cmd;
  {
    std::lock_guard lk(queue_mutex);
    check(vkQueueSubmit(queue, 1, &si, s.fence), "vkQueueSubmit", this);
  }
  check(vkWaitForFences(device, 1, &s.fence, VK_TRUE, UINT64_MAX), "vkWaitForFences", this);
  check(vkResetFences(device, 1, &s.fence), "vkResetFences", this);
}

void begin_commands(Core& core, Slot& s) {
  check(vkResetCommandPool(core.device, s.pool, 0), "vkResetCommandPool", &core);
  VkCommandBufferBeginInfo bi{};
  bi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(s.cmd, &bi), "vkBeginCommandBuffer", &core);
}

std::shared_ptr<Core> core_of(GpuContext& ctx) { return ctx.impl().core; }

}  // namespace detail

using detail::check;
using detail::Core;

std::vector<GpuDeviceInfo> list_gpu_devices(std::string* why_none) {
  VkInstance instance = VK_NULL_HANDLE;
  const VkResult r = detail::create_instance(&instance);
  if (r != VK_SUCCESS) {
    if (why_none) *why_none = "no usable Vulkan driver: vkCreateInstance failed: " + detail::vk_result_name(r);
    return {};
  }
  std::vector<GpuDeviceInfo> out;
  const auto pds = detail::physical_devices(instance, why_none);
  for (std::size_t i = 0; i < pds.size(); ++i) out.push_back(detail::describe(pds[i], static_cast<int>(i)));
  vkDestroyInstance(instance, nullptr);
  return out;
}

GpuContext::GpuContext(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
GpuContext::~GpuContext() = default;

std::unique_ptr<GpuContext> GpuContext::open(const std::string& selector) {
  auto core = std::make_shared<Core>();
  VkResult r = detail::create_instance(&core->instance);
  if (r != VK_SUCCESS) {
    core->instance = VK_NULL_HANDLE;
    throw GpuError(detail::kind_of(r) == GpuErrorKind::OutOfMemory ? GpuErrorKind::OutOfMemory : GpuErrorKind::NoVulkan,
                   "GPU: no usable Vulkan driver: vkCreateInstance failed: " + detail::vk_result_name(r));
  }
  std::string why;
  const auto pds = detail::physical_devices(core->instance, &why);
  if (pds.empty()) throw GpuError(GpuErrorKind::NoVulkan, "GPU: no Vulkan device: " + why);
  std::vector<GpuDeviceInfo> infos;
  for (std::size_t i = 0; i < pds.size(); ++i) infos.push_back(detail::describe(pds[i], static_cast<int>(i)));
  const int chosen = detail::select_device(infos, selector);
  core->physical = pds[static_cast<std::size_t>(chosen)];
  core->info = infos[static_cast<std::size_t>(chosen)];
  vkGetPhysicalDeviceProperties(core->physical, &core->props);
  vkGetPhysicalDeviceMemoryProperties(core->physical, &core->memory);
  {
    VkPhysicalDeviceMaintenance3Properties m3{};
    m3.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES;
    VkPhysicalDeviceProperties2 p2{};
    p2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
    p2.pNext = &m3;
    vkGetPhysicalDeviceProperties2(core->physical, &p2);
    core->max_allocation = m3.maxMemoryAllocationSize;
  }

  // One compute-capable queue; prefer a family with timestamps (kernel times).
  std::uint32_t nf = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(core->physical, &nf, nullptr);
  std::vector<VkQueueFamilyProperties> fams(nf);
  vkGetPhysicalDeviceQueueFamilyProperties(core->physical, &nf, fams.data());
  std::uint32_t family = UINT32_MAX;
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (!(fams[f].queueFlags & VK_QUEUE_COMPUTE_BIT) || fams[f].queueCount == 0) continue;
    if (family == UINT32_MAX || (fams[f].timestampValidBits > 0 && fams[family].timestampValidBits == 0)) family = f;
  }
  if (family == UINT32_MAX)
    throw GpuError(GpuErrorKind::NotFound, "GPU: device '" + core->info.name + "' has no compute queue");
  core->family = family;
  const std::uint32_t bits = fams[family].timestampValidBits;
  core->timestamps = bits > 0 && core->props.limits.timestampComputeAndGraphics;
  core->timestamp_mask = bits >= 64 ? ~std::uint64_t(0) : ((std::uint64_t(1) << bits) - 1);
  core->timestamp_ns = core->props.limits.timestampPeriod;

  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qi{};
  qi.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
  qi.queueFamilyIndex = family;
  qi.queueCount = 1;
  qi.pQueuePriorities = &priority;
  VkDeviceCreateInfo di{};
  di.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
  di.queueCreateInfoCount = 1;
  di.pQueueCreateInfos = &qi;
  r = vkCreateDevice(core->physical, &di, nullptr, &core->device);
  if (r != VK_SUCCESS) {
    core->device = VK_NULL_HANDLE;
    detail::throw_vk("vkCreateDevice", r);
  }
  vkGetDeviceQueue(core->device, family, 0, &core->queue);

  // Memory types. Direct mapping where the device shares host memory (CPU, integrated)
  // and a device-local type is host-visible; else device-local data + host staging.
  constexpr VkMemoryPropertyFlags DL = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, HV = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT,
                                  HC = VK_MEMORY_PROPERTY_HOST_COHERENT_BIT, CA = VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
  const auto& m = core->memory;
  const bool shares_host = core->props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU ||
                           core->props.deviceType == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU;
  const std::uint32_t direct_type = detail::find_type(m, DL | HV | HC, CA, 0);
  // RAYLINE_GPU_STAGING=1 forces the discrete-GPU path (staging copies) on any device, so
  // lavapipe tests it too.
  const char* force_staging = std::getenv("RAYLINE_GPU_STAGING");
  const bool staging = force_staging && *force_staging && std::strcmp(force_staging, "0") != 0;
  core->direct = shares_host && direct_type != UINT32_MAX && !staging;
  if (core->direct) {
    core->type_device = core->type_upload = core->type_readback = direct_type;
  } else {
    core->type_device = detail::find_type(m, DL, 0, HV);
    core->type_upload = detail::find_type(m, HV | HC, 0, DL | CA);
    core->type_readback = detail::find_type(m, HV, CA | HC, DL);
  }
  if (core->type_device == UINT32_MAX || core->type_upload == UINT32_MAX || core->type_readback == UINT32_MAX)
    throw GpuError(GpuErrorKind::Failed, "GPU: device '" + core->info.name + "' lacks a usable memory type");

  detail::create_pipelines(*core);
  core->dummy = detail::make_buffer(*core, 64, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, detail::Mem::Device, false);

  auto impl = std::make_unique<Impl>();
  impl->core = std::move(core);
  return std::unique_ptr<GpuContext>(new GpuContext(std::move(impl)));
}

const GpuDeviceInfo& GpuContext::info() const { return impl_->core->info; }
std::uint64_t GpuContext::allocated_bytes() const { return impl_->core->accounted_bytes.load(); }
bool GpuContext::lost() const { return impl_->core->lost.load(); }
std::uint64_t GpuContext::scratch_bytes() const {
  return impl_->core->scratch_bytes.load() + impl_->core->build_bytes.load();
}
void GpuContext::release_scratch() { impl_->core->release_scratch(); }
bool GpuContext::uses_staging() const { return !impl_->core->direct; }

void GpuContext::inject_fault(int after_ops, GpuErrorKind kind) {
  Core& c = *impl_->core;
  std::lock_guard lk(c.fault_mutex);
  c.fault_countdown = after_ops > 0 ? after_ops : 0;
  c.fault_kind = kind;
}

}  // namespace rayline::gpu
