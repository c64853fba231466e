// Platform files (`rayline platform check FILE`, `--platform FILE`): sched/io/platform_loader.
// The loaded graph is also asked what `platform check` prints: the shortest fetch times.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuzz_support.hpp"
#include "sched/io/platform_loader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = rayline::fuzz::write_input("platform.json", data, size);
  rayline::fuzz::expect_clean("platform", [&] {
    const rayline::DeviceGraph g = rayline::load_platform(path);
    std::vector<rayline::MemId> disks;
    for (std::size_t m = 0; m < g.memories.size(); ++m)
      if (g.memories[m].kind == rayline::MemoryKind::Disk) disks.push_back(static_cast<rayline::MemId>(m));
    (void)g.shortest_fetch_times(disks, rayline::Bytes(64) << 20);
  });
  return 0;
}
