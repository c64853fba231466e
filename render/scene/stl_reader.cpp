#include "render/scene/stl_reader.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include "sched/error.hpp"

namespace rayline::scene {
namespace {

std::uint32_t le32(const unsigned char* p) {
  return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
}
float lef(const unsigned char* p) {
  const std::uint32_t u = le32(p);
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}

struct Head {
  std::uint64_t size = 0;
  bool has_header = false, starts_solid = false;
  std::uint32_t count = 0;
};

Head read_head(const std::string& path) {
  Head h;
  std::error_code ec;
  h.size = std::filesystem::file_size(path, ec);
  if (ec) throw InputError(path, "", "cannot read STL file: " + ec.message());
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open STL file");
  unsigned char b[84] = {};
  in.read(reinterpret_cast<char*>(b), 84);
  const auto got = std::size_t(in.gcount());
  h.starts_solid = got >= 5 && std::memcmp(b, "solid", 5) == 0;
  h.has_header = got == 84;
  if (h.has_header) h.count = le32(b + 80);
  return h;
}

}  // namespace

bool is_binary_stl(const std::string& path) {
  const Head h = read_head(path);
  if (h.has_header && h.size == 84 + 50ull * h.count) return true;
  return !h.starts_solid;
}

ImportStats stream_stl(const std::string& path, const Affine& xf, const TriangleBatchFn& fn, std::size_t batch) {
  const Head h = read_head(path);
  if (!h.has_header)
    throw InputError(path, "header", "truncated binary STL: " + std::to_string(h.size) +
                                         " bytes, the 80-byte header and triangle count need 84");
  const std::uint64_t need = 84 + 50ull * h.count;
  if (h.size < need)
    throw InputError(path, "triangle_count",
                     "truncated binary STL: header says " + std::to_string(h.count) + " triangles (" +
                         std::to_string(need) + " bytes) but the file has " + std::to_string(h.size) + " bytes");
  if (h.size > need)
    throw InputError(path, "triangle_count",
                     "binary STL count mismatch: header says " + std::to_string(h.count) + " triangles (" +
                         std::to_string(need) + " bytes) but the file has " + std::to_string(h.size) + " bytes");
  std::ifstream in(path, std::ios::binary);
  in.seekg(84);
  ImportStats st;
  const bool identity = xf.is_identity();
  batch = std::max<std::size_t>(batch, 1);
  std::vector<unsigned char> raw(50 * batch);
  std::vector<Triangle> buf;
  buf.reserve(batch);
  for (std::uint64_t done = 0; done < h.count;) {
    const std::size_t n = std::size_t(std::min<std::uint64_t>(batch, h.count - done));
    in.read(reinterpret_cast<char*>(raw.data()), std::streamsize(50 * n));
    if (std::size_t(in.gcount()) != 50 * n)
      throw InputError(path, "triangle[" + std::to_string(done + std::uint64_t(in.gcount()) / 50) + "]",
                       "truncated binary STL (read failed)");
    buf.clear();
    for (std::size_t i = 0; i < n; ++i) {
      const unsigned char* r = raw.data() + 50 * i + 12;  // skip the facet normal
      Float3 v[3];
      for (int c = 0; c < 3; ++c) {
        v[c] = {lef(r + 12 * c), lef(r + 12 * c + 4), lef(r + 12 * c + 8)};
        if (!std::isfinite(v[c].x) || !std::isfinite(v[c].y) || !std::isfinite(v[c].z))
          throw InputError(path, "triangle[" + std::to_string(done + i) + "]", "non-finite vertex coordinate");
        if (!identity) v[c] = xf.point(v[c]);
        st.bounds.extend(v[c]);
      }
      buf.push_back({v[0], v[1], v[2], 0});
    }
    st.triangles += n;
    done += n;
    fn(std::span<const Triangle>(buf));
  }
  return st;
}

}  // namespace rayline::scene
