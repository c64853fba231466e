#include "render/scene/obj_reader.hpp"

#include <cmath>
#include <unordered_map>
#include <vector>

#include "render/scene/spill_file.hpp"
#include "render/scene/text_reader.hpp"
#include "render/scene/triangle_emitter.hpp"
#include "common/error.hpp"

namespace rayline::scene {
namespace {

// Spill pages are dropped from the resident set after every this many bytes of input:
// faces mostly index recent vertices, which fault straight back in from the page cache.
constexpr std::uint64_t kDropEvery = std::uint64_t(64) << 20;

class ObjParser {
 public:
  ObjParser(const std::string& path, TriangleEmitter& out) : path_(path), out_(out) {}

  // Pass 1 (`second` false): spills vertices, emits every face whose vertices are known,
  // counts skipped primitives, notes faces with forward references. Pass 2 re-reads the
  // file and emits only those faces.
  void run(bool second) {
    second_ = second;
    nv_ = 0;
    slots_.clear(), slot_ = 0, unnamed_used_ = false, any_usemtl_ = false;
    LineReader r(path_);
    std::string_view line;
    std::uint64_t bytes = 0;
    while (r.next(line)) {
      bytes += line.size() + 1;
      if (!line.empty() && line.back() == '\\') line = join_continuations(r, line);
      statement(r, line);
      if (bytes > kDropEvery) verts_.drop_resident(), bytes = 0;
    }
  }
  std::uint64_t forward_faces() const { return forward_; }

 private:
  std::string_view join_continuations(LineReader& r, std::string_view line) {
    joined_.assign(line.substr(0, line.size() - 1));
    joined_ += ' ';
    std::string_view more;
    while (r.next(more)) {
      if (!more.empty() && more.back() == '\\') {
        joined_.append(more.substr(0, more.size() - 1));
        joined_ += ' ';
      } else {
        joined_.append(more);
        break;
      }
    }
    return joined_;
  }

  [[noreturn]] void fail(const LineReader& r, const std::string& msg) const { throw InputError(path_, r.where(), msg); }

  void statement(const LineReader& r, std::string_view line) {
    Tokens t(line, true);
    const std::string_view kw = t.word();
    if (kw.empty()) return;
    if (kw == "v") {
      if (!second_) vertex(r, t);
      ++nv_;
    } else if (kw == "f") {
      face(r, t);
    } else if (kw == "usemtl") {
      std::string name(t.word());
      auto it = slots_.find(name);
      if (it == slots_.end()) it = slots_.emplace(name, std::uint32_t(slots_.size() + (unnamed_used_ ? 1 : 0))).first;
      slot_ = it->second;
      any_usemtl_ = true;
    } else if (kw == "l" || kw == "p") {
      std::uint64_t n = 0;
      while (!t.at_end()) t.skip_word(), ++n;
      if (!second_) out_.skip(kw == "p" ? n : (n > 1 ? n - 1 : 1));
    } else if (kw == "curv" || kw == "curv2" || kw == "surf") {
      if (!second_) out_.skip();
    }
    // vt, vn, vp, g, o, s, mtllib, cstype, ...: not geometry we render.
  }

  void vertex(const LineReader& r, Tokens& t) {
    Float3 p;
    if (!t.number(p.x) || !t.number(p.y) || !t.number(p.z))
      fail(r, "vertex " + std::to_string(nv_ + 1) + ": expected 3 numbers, got " + quote_token(std::string_view(t.p, t.e - t.p)));
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      fail(r, "vertex " + std::to_string(nv_ + 1) + ": non-finite coordinate");
    verts_.push_back(p);
  }

  void face(const LineReader& r, Tokens& t) {
    if (!any_usemtl_) unnamed_used_ = true;
    idx_.clear();
    bool forward = false;
    while (!t.at_end()) {
      const char* tok = t.p;
      std::int64_t v;
      if (!t.integer(v, '/')) {
        while (t.p != t.e && !is_blank(*t.p)) ++t.p;
        fail(r, "bad face index " + quote_token(std::string_view(tok, t.p - tok)));
      }
      while (t.p != t.e && !is_blank(*t.p)) ++t.p;  // "/vt/vn"
      std::int64_t a;
      if (v > 0) {
        a = v - 1;
        forward = forward || std::uint64_t(a) >= nv_;
      } else if (v < 0) {
        a = std::int64_t(nv_) + v;
        if (a < 0)
          fail(r, "face index " + std::to_string(v) + " reaches before the first vertex (" + std::to_string(nv_) +
                      " vertices so far)");
      } else {
        fail(r, "face index 0 (OBJ indices start at 1)");
      }
      idx_.push_back(std::uint64_t(a));
    }
    if (idx_.size() < 3) {
      if (!second_) out_.skip();
      return;
    }
    if (!second_ && forward) {
      ++forward_;
      return;
    }
    if (second_) {
      if (!forward) return;  // emitted in pass 1
      for (auto a : idx_)
        if (a >= verts_.size())
          fail(r, "face index " + std::to_string(a + 1) + " out of range (" + std::to_string(verts_.size()) +
                      " vertices in the file)");
    }
    const Float3 a = verts_[idx_[0]];
    Float3 b = verts_[idx_[1]];
    for (std::size_t k = 2; k < idx_.size(); ++k) {
      const Float3 c = verts_[idx_[k]];
      out_.emit(a, b, c, slot_);
      b = c;
    }
  }

  const std::string& path_;
  TriangleEmitter& out_;
  SpillArray<Float3> verts_;
  bool second_ = false;
  std::uint64_t nv_ = 0, forward_ = 0;
  std::unordered_map<std::string, std::uint32_t> slots_;
  std::uint32_t slot_ = 0;
  bool unnamed_used_ = false, any_usemtl_ = false;
  std::vector<std::uint64_t> idx_;
  std::string joined_;
};

}  // namespace

ImportStats stream_obj(const std::string& path, const Affine& xf, const TriangleBatchFn& fn, std::size_t batch) {
  ImportStats st;
  TriangleEmitter out(xf, fn, st, batch);
  ObjParser parser(path, out);
  parser.run(false);
  if (parser.forward_faces() > 0) parser.run(true);
  out.flush();
  return st;
}

}  // namespace rayline::scene
