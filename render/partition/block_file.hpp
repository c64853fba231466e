// On-disk block files of a partitioned scene (`rayline partition`).
//
// A block file holds the triangles referenced by one kd-tree cell. Layout, all
// little-endian regardless of the host:
//
//   offset size  field
//        0    8  magic            "RLBLOCK\0"
//        8    4  version          kBlockVersion (1)
//       12    4  header_bytes     kBlockHeaderBytes (128)
//       16    8  triangle_count
//       24    4  vertex_layout    kLayoutF32x9U32 (1): v0 v1 v2 as 9 float32, then uint32 material
//       28    4  record_bytes     40
//       32    4  block_id
//       36    4  block_count      blocks in the partition
//       40   24  cell             lo.xyz, hi.xyz (float32): the kd-tree cell (cells never overlap)
//       64   24  geometry_bounds  lo.xyz, hi.xyz of the triangles (may reach outside the cell)
//       88    8  payload_bytes    triangle_count * record_bytes
//       96    8  payload_crc32    zlib CRC-32 of the payload (upper 32 bits zero)
//      104   16  reserved         zero
//      120    8  header_fnv1a64   FNV-1a 64 of bytes [0, 120)
//      128    …  payload          triangle_count records
//
// read_block() verifies every field and throws InputError(file, field, message) on a
// truncated or corrupted file: never a crash, never silently wrong triangles.
#pragma once
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "render/scene/geometry.hpp"
#include "render/scene/mesh_sink.hpp"

namespace rayline::partition {

using scene::Bounds;
using scene::Float3;
using scene::Triangle;

inline constexpr char kBlockMagic[8] = {'R', 'L', 'B', 'L', 'O', 'C', 'K', '\0'};
inline constexpr std::uint32_t kBlockVersion = 1;
inline constexpr std::uint32_t kBlockHeaderBytes = 128;
inline constexpr std::uint32_t kLayoutF32x9U32 = 1;
inline constexpr std::uint32_t kRecordBytes = 40;

struct BlockHeader {
  std::uint32_t version = kBlockVersion;
  std::uint64_t triangle_count = 0;
  std::uint32_t vertex_layout = kLayoutF32x9U32;
  std::uint32_t record_bytes = kRecordBytes;
  std::uint32_t block_id = 0;
  std::uint32_t block_count = 0;
  Bounds cell;
  Bounds geometry_bounds;  // empty (inf/-inf) for an empty block
  std::uint64_t payload_bytes = 0;
  std::uint32_t payload_crc32 = 0;
};

struct BlockFile {
  BlockHeader header;
  std::vector<Triangle> triangles;
};

// Header bytes (exactly kBlockHeaderBytes) for `h`, with the header checksum filled in.
std::vector<unsigned char> encode_block_header(const BlockHeader& h);
// Parses and checks a header (magic, version, sizes, header checksum). `file` names errors.
BlockHeader decode_block_header(std::span<const unsigned char> bytes, const std::string& file);

// Appends the little-endian records of `tris` to `out`.
void encode_records(std::span<const Triangle> tris, std::vector<unsigned char>& out);
// Running CRC-32 (zlib polynomial); start with crc = 0.
std::uint32_t crc32_update(std::uint32_t crc, std::span<const unsigned char> bytes);
std::uint64_t fnv1a64(std::span<const unsigned char> bytes);

// Reads the header only, checking it and that the file size matches payload_bytes.
BlockHeader read_block_header(const std::string& path);
// Reads and verifies the whole block (header, size, payload checksum).
BlockFile read_block(const std::string& path);

}  // namespace rayline::partition
