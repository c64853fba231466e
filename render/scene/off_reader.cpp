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

// The header of an OFF file (Princeton Shape Benchmark's format): an optional keyword
// ([ST][C][N][4]OFF, or nOFF, which is refused) and the counts "vertices faces [edges]",
// on the keyword's line or the next data line.
struct OffHeader {
  std::int64_t vertices = 0, faces = 0;
  bool homogeneous = false;  // 4OFF: a fourth coordinate w divides the other three
};

// Every integer left on the line, appended to `counts`.
void take_counts(const std::string& path, const LineReader& r, Tokens& t, std::vector<std::int64_t>& counts) {
  while (!t.at_end()) {
    std::int64_t v;
    const char* at = t.p;
    if (!t.integer(v))
      throw InputError(path, "header", r.where() + ": bad count " + quote_token(Tokens(std::string_view(at, t.e - at)).word()));
    counts.push_back(v);
  }
}

// The keyword's prefix letters (S, T, C, N, 4) and a count glued to its end ("OFF8").
void read_keyword(const std::string& path, std::string_view w, std::size_t off, OffHeader& h,
                  std::vector<std::int64_t>& counts) {
  const std::string_view prefix = w.substr(0, off), rest = w.substr(off + 3);
  for (char c : prefix) {
    if (c == 'n') throw InputError(path, "header", "nOFF (dimension other than 3) is not supported");
    if (c == '4') h.homogeneous = true;
    else if (c != 'S' && c != 'T' && c != 'C' && c != 'N')
      throw InputError(path, "header", "unknown OFF keyword " + quote_token(w));
  }
  if (rest.empty()) return;
  if (!all_digits(rest)) throw InputError(path, "header", "unknown OFF keyword " + quote_token(w));
  std::int64_t v = 0;
  if (std::from_chars(rest.data(), rest.data() + rest.size(), v).ec != std::errc())
    throw InputError(path, "header", "bad count " + quote_token(rest));
  counts.push_back(v);
}

// The counts, with the keyword if there is one.
std::vector<std::int64_t> read_counts(const std::string& path, LineReader& r, std::string_view line, OffHeader& h) {
  std::vector<std::int64_t> counts;
  Tokens t(line, true);
  const char* start = t.p;
  const std::string_view w = t.word();
  std::size_t off = std::string_view::npos;
  for (std::size_t i = 0; i + 3 <= w.size(); ++i)
    if (iequals(w.substr(i, 3), "OFF")) off = i;
  if (off != std::string_view::npos) {
    read_keyword(path, w, off, h, counts);
    Tokens peek = t;
    if (iequals(peek.word(), "BINARY")) throw InputError(path, "header", "binary OFF is not supported");
  } else {
    if (w.empty() || !(w[0] >= '0' && w[0] <= '9'))
      throw InputError(path, "header", "not an OFF file: starts with " + quote_token(w));
    t.p = start;  // no keyword: this line holds the counts
  }
  take_counts(path, r, t, counts);
  if (counts.empty()) {
    if (!next_data(r, line)) throw InputError(path, "header", "no vertex and face counts (truncated)");
    Tokens c(line, true);
    take_counts(path, r, c, counts);
  }
  return counts;
}

OffHeader read_header(const std::string& path, LineReader& r) {
  std::string_view line;
  if (!next_data(r, line)) throw InputError(path, "header", "empty OFF file");
  OffHeader h;
  const std::vector<std::int64_t> counts = read_counts(path, r, line, h);
  if (counts.size() < 2 || counts.size() > 3)
    throw InputError(path, "header", r.where() + ": expected 'vertices faces [edges]', got " + std::to_string(counts.size()) + " numbers");
  h.vertices = counts[0];
  h.faces = counts[1];
  if (h.vertices < 0 || h.faces < 0) throw InputError(path, "header", "negative vertex or face count");
  std::error_code ec;
  const std::uint64_t size = std::filesystem::file_size(path, ec);
  const auto nv = std::uint64_t(h.vertices), nf = std::uint64_t(h.faces);
  // Smallest possible lines: "0 0 0\n" per vertex, "0\n" per face.
  if (!ec && (nv > size / 6 || nf > size / 2 || nv * 6 + nf * 2 > size))
    throw InputError(path, "header",
                     "counts say " + std::to_string(h.vertices) + " vertices and " + std::to_string(h.faces) +
                         " faces, more than a file of " + std::to_string(size) + " bytes can hold (bad count or truncated)");
  return h;
}

void read_vertices(const std::string& path, LineReader& r, const OffHeader& h, SpillArray<Float3>& verts) {
  verts.reserve(std::size_t(h.vertices));
  std::string_view line;
  for (std::int64_t i = 0; i < h.vertices; ++i) {
    if (!next_data(r, line))
      throw InputError(path, "vertex_count", "the header says " + std::to_string(h.vertices) +
                                                 " vertices but the file ends after " + std::to_string(i) + " (truncated)");
    Tokens t(line, true);
    Float3 p;
    float w = 1;
    if (!t.number(p.x) || !t.number(p.y) || !t.number(p.z) || (h.homogeneous && !t.number(w)))
      throw InputError(path, r.where(), "vertex " + std::to_string(i) + ": expected " + (h.homogeneous ? "4" : "3") +
                                            " numbers, got " + quote_token(line));
    if (h.homogeneous) p = p * (1.0f / w);
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw InputError(path, r.where(), "vertex " + std::to_string(i) + ": non-finite coordinate");
    verts.push_back(p);
  }
}

// Face f's vertex indices, each checked against the vertex count.
void read_face(const std::string& path, const LineReader& r, std::string_view line, std::int64_t f,
               std::int64_t nv, std::vector<std::uint64_t>& idx) {
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
}

}  // namespace

ImportStats stream_off(const std::string& path, const Affine& xf, const TriangleBatchFn& fn, std::size_t batch) {
  LineReader r(path);
  const OffHeader h = read_header(path, r);
  SpillArray<Float3> verts;
  read_vertices(path, r, h, verts);

  ImportStats st;
  TriangleEmitter out(xf, fn, st, batch);
  std::vector<std::uint64_t> idx;
  std::uint64_t bytes = 0;
  std::string_view line;
  for (std::int64_t f = 0; f < h.faces; ++f) {
    if (!next_data(r, line))
      throw InputError(path, "face_count", "the header says " + std::to_string(h.faces) + " faces but the file ends after " +
                                               std::to_string(f) + " (truncated)");
    bytes += line.size() + 1;
    if (bytes > kDropEvery) verts.drop_resident(), bytes = 0;
    read_face(path, r, line, f, h.vertices, idx);
    if (idx.size() < 3) {
      out.skip();
      continue;
    }
    // A polygon becomes a fan around its first vertex.
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
