// Reading a block file the way the disk→RAM channel must be measured: with
// O_DIRECT, so the OS page cache never turns a later read into a memory copy. Where the
// file system refuses O_DIRECT (tmpfs, some overlay file systems) the file is read
// normally and its pages are dropped afterwards (posix_fadvise DONTNEED); which of the
// two happened is reported per read.
#pragma once
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "render/partition/block_file.hpp"

namespace rayline::engine {

enum class ReadMode : std::uint8_t { Direct, Buffered };

struct RawBlock {
  partition::BlockHeader header;
  std::unique_ptr<unsigned char, void (*)(void*)> buffer{nullptr, nullptr};
  std::span<const unsigned char> payload;  // verified: size and CRC-32
  std::uint64_t file_bytes = 0;
  ReadMode mode = ReadMode::Direct;
};

// Reads and verifies `path` (header, size, payload checksum). Throws InputError(path,
// field, message) on a missing, truncated or corrupted file.
RawBlock read_block_uncached(const std::string& path, bool allow_direct = true);

}  // namespace rayline::engine
