#include "render/partition/block_file.hpp"

#include <zlib.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

#include "render/scene/little_endian.hpp"
#include "common/error.hpp"

namespace rayline::partition {
namespace {

constexpr std::size_t kChecksumOffset = 120;

using scene::get_le;
using scene::put_le;
void put_bounds(unsigned char* p, const Bounds& b) {
  for (int i = 0; i < 3; ++i) put_le<float>(p + 4 * i, b.lo[i]), put_le<float>(p + 12 + 4 * i, b.hi[i]);
}
Bounds get_bounds(const unsigned char* p) {
  Bounds b;
  for (int i = 0; i < 3; ++i) b.lo[i] = get_le<float>(p + 4 * i), b.hi[i] = get_le<float>(p + 12 + 4 * i);
  return b;
}

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

FilePtr open_block(const std::string& path, std::uint64_t& size) {
  FilePtr f(std::fopen(path.c_str(), "rb"));
  if (!f) throw InputError(path, "", "cannot open block file");
  if (std::fseek(f.get(), 0, SEEK_END) != 0) throw InputError(path, "", "cannot seek");
  const long s = std::ftell(f.get());
  if (s < 0) throw InputError(path, "", "cannot determine size");
  size = static_cast<std::uint64_t>(s);
  std::rewind(f.get());
  return f;
}

BlockHeader read_header_checked(std::FILE* f, std::uint64_t size, const std::string& path) {
  if (size < kBlockHeaderBytes)
    throw InputError(path, "header", "truncated: file has " + std::to_string(size) + " bytes, header needs " +
                                         std::to_string(kBlockHeaderBytes));
  std::vector<unsigned char> hb(kBlockHeaderBytes);
  if (std::fread(hb.data(), 1, hb.size(), f) != hb.size()) throw InputError(path, "header", "read failed");
  BlockHeader h = decode_block_header(hb, path);
  const std::uint64_t expect = std::uint64_t(kBlockHeaderBytes) + h.payload_bytes;
  if (size < expect)
    throw InputError(path, "payload_bytes", "truncated: file has " + std::to_string(size) + " bytes, header says " +
                                                std::to_string(expect));
  if (size > expect)
    throw InputError(path, "payload_bytes", "file has " + std::to_string(size - expect) +
                                                " trailing bytes beyond the declared payload");
  return h;
}

}  // namespace

std::uint64_t fnv1a64(std::span<const unsigned char> bytes) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char c : bytes) h = (h ^ c) * 0x100000001b3ull;
  return h;
}

std::uint32_t crc32_update(std::uint32_t crc, std::span<const unsigned char> bytes) {
  uLong c = crc;
  const unsigned char* p = bytes.data();
  std::size_t n = bytes.size();
  while (n > 0) {
    const std::size_t step = std::min<std::size_t>(n, 1u << 30);
    c = ::crc32(c, p, static_cast<uInt>(step));
    p += step, n -= step;
  }
  return static_cast<std::uint32_t>(c);
}

std::vector<unsigned char> encode_block_header(const BlockHeader& h) {
  std::vector<unsigned char> b(kBlockHeaderBytes, 0);
  std::memcpy(b.data(), kBlockMagic, 8);
  put_le<std::uint32_t>(&b[8], h.version);
  put_le<std::uint32_t>(&b[12], kBlockHeaderBytes);
  put_le<std::uint64_t>(&b[16], h.triangle_count);
  put_le<std::uint32_t>(&b[24], h.vertex_layout);
  put_le<std::uint32_t>(&b[28], h.record_bytes);
  put_le<std::uint32_t>(&b[32], h.block_id);
  put_le<std::uint32_t>(&b[36], h.block_count);
  put_bounds(&b[40], h.cell);
  put_bounds(&b[64], h.geometry_bounds);
  put_le<std::uint64_t>(&b[88], h.payload_bytes);
  put_le<std::uint64_t>(&b[96], h.payload_crc32);
  put_le<std::uint64_t>(&b[kChecksumOffset], fnv1a64(std::span(b.data(), kChecksumOffset)));
  return b;
}

BlockHeader decode_block_header(std::span<const unsigned char> b, const std::string& file) {
  if (b.size() < kBlockHeaderBytes) throw InputError(file, "header", "truncated header");
  if (std::memcmp(b.data(), kBlockMagic, 8) != 0) throw InputError(file, "magic", "not a Rayline block file");
  BlockHeader h;
  h.version = get_le<std::uint32_t>(&b[8]);
  if (h.version != kBlockVersion)
    throw InputError(file, "version",
                     "unsupported version " + std::to_string(h.version) + " (expected " + std::to_string(kBlockVersion) + ")");
  const auto stored = get_le<std::uint64_t>(&b[kChecksumOffset]);
  if (stored != fnv1a64(b.first(kChecksumOffset)))
    throw InputError(file, "header_checksum", "header checksum mismatch (corrupted header)");
  if (get_le<std::uint32_t>(&b[12]) != kBlockHeaderBytes)
    throw InputError(file, "header_bytes", "unexpected header size " + std::to_string(get_le<std::uint32_t>(&b[12])));
  h.triangle_count = get_le<std::uint64_t>(&b[16]);
  h.vertex_layout = get_le<std::uint32_t>(&b[24]);
  h.record_bytes = get_le<std::uint32_t>(&b[28]);
  if (h.vertex_layout != kLayoutF32x9U32)
    throw InputError(file, "vertex_layout", "unknown vertex layout " + std::to_string(h.vertex_layout));
  if (h.record_bytes != kRecordBytes)
    throw InputError(file, "record_bytes", "expected " + std::to_string(kRecordBytes) + ", got " +
                                               std::to_string(h.record_bytes));
  h.block_id = get_le<std::uint32_t>(&b[32]);
  h.block_count = get_le<std::uint32_t>(&b[36]);
  if (h.block_count == 0 || h.block_id >= h.block_count)
    throw InputError(file, "block_id", "block " + std::to_string(h.block_id) + " of " + std::to_string(h.block_count));
  h.cell = get_bounds(&b[40]);
  h.geometry_bounds = get_bounds(&b[64]);
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(h.cell.lo[i]) || !std::isfinite(h.cell.hi[i]) || h.cell.lo[i] > h.cell.hi[i])
      throw InputError(file, "cell", "invalid cell bounds");
  h.payload_bytes = get_le<std::uint64_t>(&b[88]);
  if (h.triangle_count > (std::uint64_t(1) << 40) || h.payload_bytes != h.triangle_count * kRecordBytes)
    throw InputError(file, "payload_bytes", "payload_bytes " + std::to_string(h.payload_bytes) +
                                                " does not match triangle_count " + std::to_string(h.triangle_count));
  const auto crc = get_le<std::uint64_t>(&b[96]);
  if (crc > 0xffffffffull) throw InputError(file, "payload_crc32", "out of range");
  h.payload_crc32 = static_cast<std::uint32_t>(crc);
  return h;
}

void encode_records(std::span<const Triangle> tris, std::vector<unsigned char>& out) {
  const std::size_t at = out.size();
  out.resize(at + tris.size() * kRecordBytes);
  unsigned char* p = out.data() + at;
  for (const Triangle& t : tris) {
    const float f[9] = {t.v0.x, t.v0.y, t.v0.z, t.v1.x, t.v1.y, t.v1.z, t.v2.x, t.v2.y, t.v2.z};
    if constexpr (std::endian::native == std::endian::little) {
      std::memcpy(p, f, 36);
      std::memcpy(p + 36, &t.material, 4);
    } else {
      for (int i = 0; i < 9; ++i) put_le<float>(p + 4 * i, f[i]);
      put_le<std::uint32_t>(p + 36, t.material);
    }
    p += kRecordBytes;
  }
}

BlockHeader read_block_header(const std::string& path) {
  std::uint64_t size = 0;
  FilePtr f = open_block(path, size);
  return read_header_checked(f.get(), size, path);
}

BlockFile read_block(const std::string& path) {
  std::uint64_t size = 0;
  FilePtr f = open_block(path, size);
  BlockFile out;
  out.header = read_header_checked(f.get(), size, path);
  const std::uint64_t n = out.header.triangle_count;
  out.triangles.resize(n);
  std::vector<unsigned char> buf;
  std::uint32_t crc = 0;
  const std::uint64_t chunk = 1 << 16;  // records per read
  for (std::uint64_t done = 0; done < n;) {
    const std::uint64_t k = std::min(chunk, n - done);
    buf.resize(k * kRecordBytes);
    if (std::fread(buf.data(), 1, buf.size(), f.get()) != buf.size())
      throw InputError(path, "payload", "read failed (file truncated while reading?)");
    crc = crc32_update(crc, buf);
    for (std::uint64_t i = 0; i < k; ++i) {
      const unsigned char* p = buf.data() + i * kRecordBytes;
      Triangle& t = out.triangles[done + i];
      t.v0 = {get_le<float>(p), get_le<float>(p + 4), get_le<float>(p + 8)};
      t.v1 = {get_le<float>(p + 12), get_le<float>(p + 16), get_le<float>(p + 20)};
      t.v2 = {get_le<float>(p + 24), get_le<float>(p + 28), get_le<float>(p + 32)};
      t.material = get_le<std::uint32_t>(p + 36);
    }
    done += k;
  }
  if (crc != out.header.payload_crc32)
    throw InputError(path, "payload_crc32", "payload checksum mismatch (corrupted block)");
  return out;
}

}  // namespace rayline::partition
