#include "render/scene/stl_reader.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include "render/scene/text_reader.hpp"
#include "render/scene/triangle_emitter.hpp"
#include "common/error.hpp"

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
  bool has_header = false, starts_solid = false, has_nul = false;
  std::uint32_t count = 0;
};

Head read_head(const std::string& path) {
  Head h;
  std::error_code ec;
  h.size = std::filesystem::file_size(path, ec);
  if (ec) throw InputError(path, "", "cannot read STL file: " + ec.message());
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open STL file");
  unsigned char b[512] = {};
  in.read(reinterpret_cast<char*>(b), sizeof b);
  const auto got = std::size_t(in.gcount());
  h.starts_solid = got >= 5 && std::memcmp(b, "solid", 5) == 0;
  h.has_nul = std::memchr(b, 0, got) != nullptr;
  h.has_header = got >= 84;
  if (h.has_header) h.count = le32(b + 80);
  return h;
}

}  // namespace

bool is_binary_stl(const std::string& path) {
  const Head h = read_head(path);
  if (h.has_header && h.size == 84 + 50ull * h.count) return true;
  return !h.starts_solid || h.has_nul;
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

ImportStats stream_ascii_stl(const std::string& path, const Affine& xf, const TriangleBatchFn& fn, std::size_t batch) {
  enum class In { nothing, solid, facet, loop } in = In::nothing;
  LineReader r(path);
  ImportStats st;
  TriangleEmitter out(xf, fn, st, batch);
  std::vector<Float3> loop;
  bool any_solid = false;
  std::string_view line;
  auto fail = [&](const std::string& msg) { throw InputError(path, r.where(), msg); };
  auto expect = [&](In state, std::string_view kw) {
    if (in != state) fail("unexpected " + quote_token(kw) + (in == In::nothing ? " outside a solid" : ""));
  };
  while (r.next(line)) {
    Tokens t(line);
    const std::string_view kw = t.word();
    if (kw.empty()) continue;
    if (iequals(kw, "vertex")) {
      expect(In::loop, kw);
      Float3 v;
      if (!t.number(v.x) || !t.number(v.y) || !t.number(v.z))
        fail("vertex: expected 3 numbers, got " + quote_token(std::string_view(t.p, std::size_t(t.e - t.p))));
      if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) fail("non-finite vertex coordinate");
      loop.push_back(v);
    } else if (iequals(kw, "facet")) {
      expect(In::solid, kw);
      in = In::facet;
    } else if (iequals(kw, "outer")) {
      expect(In::facet, kw);
      in = In::loop;
      loop.clear();
    } else if (iequals(kw, "endloop")) {
      expect(In::loop, kw);
      in = In::facet;
    } else if (iequals(kw, "endfacet")) {
      expect(In::facet, kw);
      if (loop.size() < 3) {
        out.skip();
      } else {
        for (std::size_t k = 2; k < loop.size(); ++k) out.emit(loop[0], loop[k - 1], loop[k], 0);
      }
      loop.clear();
      in = In::solid;
    } else if (iequals(kw, "endsolid")) {
      expect(In::solid, kw);
      in = In::nothing;
    } else if (iequals(kw, "solid")) {
      if (in != In::nothing) fail("'solid' inside a solid");
      in = In::solid;
      any_solid = true;
    } else if (!any_solid) {
      throw InputError(path, "header", "not an ASCII STL: starts with " + quote_token(kw) + ", not 'solid'");
    } else {
      fail("unexpected " + quote_token(kw));
    }
  }
  if (!any_solid) throw InputError(path, "header", "not an ASCII STL: no 'solid' line");
  if (in == In::facet || in == In::loop) fail("file ends inside a facet (truncated)");
  if (in == In::solid) fail("file ends without 'endsolid' (truncated)");
  out.flush();
  return st;
}

}  // namespace rayline::scene
