// Block files (what `rayline partition` writes, block_file.hpp's layout; read by
// `rayline render --blocks-dir`): the header check the renderer runs on every block
// before it starts (partition::read_block_header), the O_DIRECT read of a T-job
// (render/store/block_reader.cpp) and the whole-block reader (partition::read_block).
//
// Each input runs twice: as it is, and with its two checksums (the header's FNV-1a at
// byte 120, the payload's CRC-32 at byte 96) recomputed, so that mutations reach the
// checks behind them instead of stopping at a checksum mismatch.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "fuzz_support.hpp"
#include "render/partition/block_file.hpp"
#include "render/store/block_reader.hpp"

namespace {

void read_all_ways(const std::uint8_t* data, std::size_t size) {
  const std::string path = rayline::fuzz::write_input("block_00000.rlb", data, size);
  rayline::fuzz::expect_clean("block", [&] { (void)rayline::partition::read_block_header(path); });
  rayline::fuzz::expect_clean("block", [&] { (void)rayline::engine::read_block_uncached(path); });
  rayline::fuzz::expect_clean("block", [&] { (void)rayline::partition::read_block(path); });
}

void put_u64(std::uint8_t* p, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  read_all_ways(data, size);
  constexpr std::size_t kHeader = rayline::partition::kBlockHeaderBytes;
  if (size < kHeader) return 0;
  std::vector<std::uint8_t> fixed(data, data + size);
  put_u64(&fixed[96], rayline::partition::crc32_update(0, std::span<const unsigned char>(fixed).subspan(kHeader)));
  put_u64(&fixed[120], rayline::partition::fnv1a64(std::span<const unsigned char>(fixed).first(120)));
  if (!std::equal(fixed.begin(), fixed.end(), data)) read_all_ways(fixed.data(), fixed.size());
  return 0;
}
