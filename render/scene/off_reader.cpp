#include "render/scene/off_reader.hpp"

#include <cmath>
#include <filesystem>
#include <vector>

#include "render/scene/spill_file.hpp"
#include "render/scene/text_reader.hpp"
#include "render/scene/triangle_emitter.hpp"
#include "common/error.hpp"

namespace rayline::scene {
namespace {

constexpr std::uint64_t kDropEvery = std::uint64_t(64) << 20;

// The next line with data (comments and blank lines skipped).
bool next_data(LineReader& r, std::string_view& line) {
  while (r.next(line)) {
    Tokens t(line, true);
    if (!t.at_end()) return true;
  }
  return false;
}

bool all_digits(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s)
    if (c < '0' || c > '9') return false;
  return true;
}

}  // namespace

ImportStats stream_off(const std::string& path, const Affine& xf, const TriangleBatchFn& fn, std::size_t batch) {
  LineReader r(path);
  std::string_view line;
  if (!next_data(r, line)) throw InputError(path, "header", "empty OFF file");

  // Keyword (optional) and counts.
  bool homogeneous = false;
  std::vector<std::int64_t> counts;
  auto take_counts = [&](Tokens& t) {
    while (!t.at_end()) {
      std::int64_t v;
      const char* at = t.p;
      if (!t.integer(v))
        throw InputError(path, "header", r.where() + ": bad count " + quote_token(Tokens(std::string_view(at, t.e - at)).word()));
      counts.push_back(v);
    }
  };
  {
    Tokens t(line, true);
    const char* start = t.p;
    const std::string_view w = t.word();
    std::size_t off = std::string_view::npos;
    for (std::size_t i = 0; i + 3 <= w.size(); ++i)
      if (iequals(w.substr(i, 3), "OFF")) off = i;
    if (off != std::string_view::npos) {
      const std::string_view prefix = w.substr(0, off), rest = w.substr(off + 3);
      for (char c : prefix) {
        if (c == 'n') throw InputError(path, "header", "nOFF (dimension other than 3) is not supported");
        if (c == '4') homogeneous = true;
        else if (c != 'S' && c != 'T' && c != 'C' && c != 'N')
          throw InputError(path, "header", "unknown OFF keyword " + quote_token(w));
      }
      if (!rest.empty()) {
        if (!all_digits(rest)) throw InputError(path, "header", "unknown OFF keyword " + quote_token(w));
        std::int64_t v = 0;
        if (std::from_chars(rest.data(), rest.data() + rest.size(), v).ec != std::errc())
          throw InputError(path, "header", "bad count " + quote_token(rest));
        counts.push_back(v);
      }
      Tokens peek = t;
      if (iequals(peek.word(), "BINARY")) throw InputError(path, "header", "binary OFF is not supported");
    } else {
      if (w.empty() || !(w[0] >= '0' && w[0] <= '9'))
        throw InputError(path, "header", "not an OFF file: starts with " + quote_token(w));
      t.p = start;  // no keyword: this line holds the counts
    }
    take_counts(t);
    if (counts.empty()) {
      if (!next_data(r, line)) throw InputError(path, "header", "no vertex and face counts (truncated)");
      Tokens c(line, true);
      take_counts(c);
    }
  }
  if (counts.size() < 2 || counts.size() > 3)
    throw InputError(path, "header", r.where() + ": expected 'vertices faces [edges]', got " + std::to_string(counts.size()) + " numbers");
  const std::int64_t nv = counts[0], nf = counts[1];
  if (nv < 0 || nf < 0) throw InputError(path, "header", "negative vertex or face count");
  std::error_code ec;
  const std::uint64_t size = std::filesystem::file_size(path, ec);
  // Smallest possible lines: "0 0 0\n" per vertex, "0\n" per face.
  if (!ec && (std::uint64_t(nv) > size / 6 || std::uint64_t(nf) > size / 2 ||
              std::uint64_t(nv) * 6 + std::uint64_t(nf) * 2 > size))
    throw InputError(path, "header",
                     "counts say " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
                         " faces, more than a file of " + std::to_string(size) + " bytes can hold (bad count or truncated)");

  SpillArray<Float3> verts;
  verts.reserve(std::size_t(nv));
  for (std::int64_t i = 0; i < nv; ++i) {
    if (!next_data(r, line))
      throw InputError(path, "vertex_count", "the header says " + std::to_string(nv) + " vertices but the file ends after " +
                                                 std::to_string(i) + " (truncated)");
    Tokens t(line, true);
    Float3 p;
    float w = 1;
    if (!t.number(p.x) || !t.number(p.y) || !t.number(p.z) || (homogeneous && !t.number(w)))
      throw InputError(path, r.where(), "vertex " + std::to_string(i) + ": expected " + (homogeneous ? "4" : "3") +
                                            " numbers, got " + quote_token(line));
    if (homogeneous) p = p * (1.0f / w);
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw InputError(path, r.where(), "vertex " + std::to_string(i) + ": non-finite coordinate");
    verts.push_back(p);
  }

  ImportStats st;
  TriangleEmitter out(xf, fn, st, batch);
  std::vector<std::uint64_t> idx;
  std::uint64_t bytes = 0;
  for (std::int64_t f = 0; f < nf; ++f) {
    if (!next_data(r, line))
      throw InputError(path, "face_count", "the header says " + std::to_string(nf) + " faces but the file ends after " +
                                               std::to_string(f) + " (truncated)");
    bytes += line.size() + 1;
    if (bytes > kDropEvery) verts.drop_resident(), bytes = 0;
    Tokens t(line, true);
    std::int64_t n;
    if (!t.integer(n) || n < 0)
      throw InputError(path, r.where(), "face " + std::to_string(f) + ": bad vertex count " + quote_token(line));
    idx.clear();
    for (std::int64_t k = 0; k < n; ++k) {
      std::int64_t i;
      if (!t.integer(i))
        throw InputError(path, r.where(), "face " + std::to_string(f) + ": expected " + std::to_string(n) +
                                              " vertex indices, got " + quote_token(line));
      if (i < 0 || i >= nv)
        throw InputError(path, r.where(), "face " + std::to_string(f) + ": vertex index " + std::to_string(i) +
                                              " out of range (" + std::to_string(nv) + " vertices)");
      idx.push_back(std::uint64_t(i));
    }
    if (n < 3) {
      out.skip();
      continue;
    }
    const Float3 a = verts[idx[0]];
    Float3 b = verts[idx[1]];
    for (std::size_t k = 2; k < idx.size(); ++k) {
      const Float3 c = verts[idx[k]];
      out.emit(a, b, c, 0);
      b = c;
    }
  }
  out.flush();
  return st;
}

}  // namespace rayline::scene
