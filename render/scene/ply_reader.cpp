#include "render/scene/ply_reader.hpp"

#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "render/scene/mapped_file.hpp"
#include "render/scene/spill_file.hpp"
#include "render/scene/text_reader.hpp"
#include "render/scene/triangle_emitter.hpp"
#include "common/error.hpp"

namespace rayline::scene {
namespace {

// Resident pages are dropped after every this many bytes of face data.
constexpr std::size_t kDropEvery = std::size_t(64) << 20;

enum class Type { i8, u8, i16, u16, i32, u32, f32, f64, invalid };

Type parse_type(const std::string& s) {
  if (s == "char" || s == "int8") return Type::i8;
  if (s == "uchar" || s == "uint8") return Type::u8;
  if (s == "short" || s == "int16") return Type::i16;
  if (s == "ushort" || s == "uint16") return Type::u16;
  if (s == "int" || s == "int32") return Type::i32;
  if (s == "uint" || s == "uint32") return Type::u32;
  if (s == "float" || s == "float32") return Type::f32;
  if (s == "double" || s == "float64") return Type::f64;
  return Type::invalid;
}
std::size_t type_size(Type t) {
  switch (t) {
    case Type::i8: case Type::u8: return 1;
    case Type::i16: case Type::u16: return 2;
    case Type::i32: case Type::u32: case Type::f32: return 4;
    case Type::f64: return 8;
    default: return 0;
  }
}
bool is_integer(Type t) { return t != Type::f32 && t != Type::f64 && t != Type::invalid; }

struct Property {
  std::string name;
  Type type = Type::invalid;
  bool list = false;
  Type count_type = Type::invalid;
  bool is_index_list() const { return list && (name == "vertex_indices" || name == "vertex_index"); }
  int axis() const { return list ? -1 : name == "x" ? 0 : name == "y" ? 1 : name == "z" ? 2 : -1; }
};
// What a reader does with a property, decided once per file (not per face).
enum class Role : std::uint8_t { skip, skip_list, x, y, z, indices, material };
Role role(const Property& p) {
  if (p.is_index_list()) return Role::indices;
  if (p.list) return Role::skip_list;
  if (p.name == "material_index") return Role::material;
  const int a = p.axis();
  return a == 0 ? Role::x : a == 1 ? Role::y : a == 2 ? Role::z : Role::skip;
}

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> props;
  bool fixed() const {
    for (auto& p : props)
      if (p.list) return false;
    return true;
  }
  std::size_t stride() const {
    std::size_t s = 0;
    for (auto& p : props) s += type_size(p.type);
    return s;
  }
};

// What no PLY reader can read, judged here rather than handed to assimp (whose PLY
// loader and post-processing crash on it): a list whose length is not an integer type,
// a vertex index list whose items are not, and a property name an element repeats.
void check_property(const std::string& path, const Element& e, const Property& p, const std::string& line) {
  if (p.list && !is_integer(p.count_type))
    throw InputError(path, "header.property", "list length type must be an integer type in '" + line + "'");
  if (p.is_index_list() && !is_integer(p.type))
    throw InputError(path, "header.property", "vertex index type must be an integer type in '" + line + "'");
  for (const Property& q : e.props) {
    if (q.name == p.name)
      throw InputError(path, "header.property", "element '" + e.name + "' declares property '" + p.name + "' twice");
    if (q.is_index_list() && p.is_index_list())
      throw InputError(path, "header.property", "element '" + e.name + "' has two vertex index lists ('" + q.name +
                                                    "' and '" + p.name + "')");
  }
}

struct Header {
  PlyHeaderInfo info;
  std::vector<Element> elements;
  std::size_t bytes = 0;       // header length, up to and including "end_header\n"
  std::uint64_t lines = 0;     // header lines
  int vertex = -1, face = -1;  // element indices
};

void read_format_line(const std::string& path, std::istringstream& ls, Header& h) {
  std::string f;
  ls >> f;
  h.info.binary = f != "ascii";
  h.info.big_endian = f == "binary_big_endian";
  if (f != "ascii" && f != "binary_little_endian" && f != "binary_big_endian")
    throw InputError(path, "header.format", "unknown PLY format '" + f + "'");
}

void read_element_line(const std::string& path, std::istringstream& ls, const std::string& line, Header& h) {
  Element e;
  ls >> e.name >> e.count;
  if (!ls) throw InputError(path, "header.element", "malformed element line '" + line + "'");
  for (const Element& other : h.elements)
    if (other.name == e.name) throw InputError(path, "header.element", "element '" + e.name + "' declared twice");
  h.elements.push_back(e);
}

void read_property_line(const std::string& path, std::istringstream& ls, const std::string& line, Header& h) {
  if (h.elements.empty()) throw InputError(path, "header.property", "property before any element");
  Property p;
  std::string t;
  ls >> t;
  if (t == "list") {
    std::string ct, it;
    ls >> ct >> it >> p.name;
    p.list = true, p.count_type = parse_type(ct), p.type = parse_type(it);
  } else {
    p.type = parse_type(t);
    ls >> p.name;
  }
  if (!ls || p.type == Type::invalid || (p.list && p.count_type == Type::invalid))
    throw InputError(path, "header.property", "malformed property line '" + line + "'");
  check_property(path, h.elements.back(), p, line);
  h.elements.back().props.push_back(p);
}

// Native streaming needs: vertex with scalar x, y, z (binary: and no lists); face with
// exactly one integer vertex index list; every list length an integer.
bool natively_streamable(const Header& h) {
  if (h.vertex < 0 || h.face < 0) return false;
  const Element& v = h.elements[std::size_t(h.vertex)];
  int xyz[3] = {0, 0, 0};
  for (auto& p : v.props)
    if (p.axis() >= 0) ++xyz[p.axis()];
  bool ok = xyz[0] == 1 && xyz[1] == 1 && xyz[2] == 1 && (!h.info.binary || v.fixed());
  int lists = 0;
  for (auto& p : h.elements[std::size_t(h.face)].props)
    if (p.is_index_list()) ++lists, ok = ok && is_integer(p.type);
  ok = ok && lists == 1;
  for (auto& e : h.elements)  // list lengths must be integers to be walked
    for (auto& p : e.props) ok = ok && (!p.list || is_integer(p.count_type));
  return ok;
}

Header parse_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open mesh file");
  Header h;
  std::string line;
  if (!std::getline(in, line) || line.substr(0, 3) != "ply") throw InputError(path, "header", "not a PLY file");
  bool ended = false, format = false;
  std::size_t bytes = line.size() + 1;
  std::uint64_t lines = 1;
  while (!ended && std::getline(in, line)) {
    bytes += line.size() + 1;
    ++lines;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string kw;
    ls >> kw;
    if (kw == "format") read_format_line(path, ls, h), format = true;
    else if (kw == "element") read_element_line(path, ls, line, h);
    else if (kw == "property") read_property_line(path, ls, line, h);
    else if (kw == "end_header") ended = true;
    else if (!kw.empty() && kw != "comment" && kw != "obj_info")
      // Not PLY: the native reader would ignore the line, and then hand the file to assimp,
      // whose PLY loader leaks what it allocated before it fails on such headers.
      throw InputError(path, "header", "line " + std::to_string(lines) + ": unknown header keyword '" + kw +
                                           "' (a PLY header holds format, comment, obj_info, element, property "
                                           "and end_header lines)");
  }
  if (!ended) throw InputError(path, "header", "no end_header (truncated or not a PLY file)");
  if (!format) throw InputError(path, "header.format", "no format line");
  h.bytes = bytes;
  h.lines = lines;
  for (std::size_t k = 0; k < h.elements.size(); ++k) {
    const Element& e = h.elements[k];
    if (e.name == "vertex" && h.vertex < 0) h.vertex = int(k), h.info.vertices = e.count;
    if (e.name == "face" && h.face < 0) h.face = int(k), h.info.faces = e.count;
  }
  h.info.streamable = natively_streamable(h);
  return h;
}

// ---------------------------------------------------------------------------------------
// Binary

template <class T>
T load(const unsigned char* p, bool swap) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if (swap)
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

double scalar(const unsigned char* p, Type t, bool swap) {
  switch (t) {
    case Type::i8: return double(static_cast<std::int8_t>(*p));
    case Type::u8: return double(*p);
    case Type::i16: return load<std::int16_t>(p, swap);
    case Type::u16: return load<std::uint16_t>(p, swap);
    case Type::i32: return load<std::int32_t>(p, swap);
    case Type::u32: return load<std::uint32_t>(p, swap);
    case Type::f32: return load<float>(p, swap);
    case Type::f64: return load<double>(p, swap);
    default: return 0;
  }
}

// A face's material slot: a value in [0, 2^32) (its fraction dropped). Converting a
// negative, huge or NaN value to an unsigned integer would be undefined behaviour (found
// by fuzzing: a binary int material_index of -2^31).
bool material_slot(double v, std::uint32_t& slot) {
  if (!(v >= 0 && v < 4294967296.0)) return false;
  slot = static_cast<std::uint32_t>(v);
  return true;
}

std::uint32_t binary_material(const std::string& path, std::uint64_t face, double v) {
  std::uint32_t slot = 0;
  if (!material_slot(v, slot))
    throw InputError(path, "face.material_index", "face " + std::to_string(face) + ": material index " +
                                                       std::to_string(v) + " is not a slot number (0 to 4294967295)");
  return slot;
}

// The end of element `e`'s data starting at `p` (walking its lists when it has any).
const unsigned char* skip_element(const std::string& path, const Element& e, const unsigned char* p,
                                  const unsigned char* end, bool swap) {
  auto truncated = [&]() { return InputError(path, e.name, "file truncated inside the " + e.name + " data"); };
  if (e.fixed()) {
    const std::size_t stride = e.stride();
    if (stride > 0 && e.count > std::uint64_t(end - p) / stride) throw truncated();
    return p + stride * e.count;
  }
  for (std::uint64_t i = 0; i < e.count; ++i)
    for (auto& prop : e.props) {
      if (prop.list) {
        const std::size_t cs = type_size(prop.count_type);
        if (std::size_t(end - p) < cs) throw truncated();
        const double n = scalar(p, prop.count_type, swap);
        p += cs;
        if (n < 0 || n * double(type_size(prop.type)) > double(end - p)) throw truncated();
        p += std::size_t(n) * type_size(prop.type);
      } else {
        if (std::size_t(end - p) < type_size(prop.type)) throw truncated();
        p += type_size(prop.type);
      }
    }
  return p;
}

ImportStats stream_binary(const std::string& path, const Header& h, const Affine& xf, const TriangleBatchFn& fn,
                          std::size_t batch) {
  const bool swap = h.info.big_endian != (std::endian::native == std::endian::big);
  const MappedFile map(path);
  const unsigned char* end = map.data() + map.size();
  const Element& vertex = h.elements[std::size_t(h.vertex)];
  const Element& face = h.elements[std::size_t(h.face)];

  // Where the vertex and face elements start: walk the elements before the later one.
  const unsigned char* vbase = nullptr;
  const unsigned char* fbase = nullptr;
  const unsigned char* p = map.data() + std::min(h.bytes, map.size());
  for (int k = 0; k <= std::max(h.vertex, h.face); ++k) {
    if (k == h.vertex) vbase = p;
    if (k == h.face) fbase = p;
    if (k < std::max(h.vertex, h.face)) p = skip_element(path, h.elements[std::size_t(k)], p, end, swap);
  }
  const std::size_t vstride = vertex.stride();
  if (vstride > 0 && vertex.count > std::uint64_t(end - vbase) / vstride)
    throw InputError(path, "vertex", "file truncated inside the vertex data");
  std::size_t xyz_off[3] = {0, 0, 0};
  Type xyz_type[3] = {Type::f32, Type::f32, Type::f32};
  {
    std::size_t o = 0;
    for (auto& prop : vertex.props) {
      if (prop.axis() >= 0) xyz_off[prop.axis()] = o, xyz_type[prop.axis()] = prop.type;
      o += type_size(prop.type);
    }
  }
  const bool fast_xyz = !swap && xyz_type[0] == Type::f32 && xyz_type[1] == Type::f32 && xyz_type[2] == Type::f32;
  const std::uint64_t nv = vertex.count;
  auto position = [&](std::int64_t i) -> Float3 {
    if (i < 0 || std::uint64_t(i) >= nv)
      throw InputError(path, "face.vertex_indices", "index " + std::to_string(i) + " out of range (" +
                                                        std::to_string(nv) + " vertices)");
    const unsigned char* q = vbase + std::size_t(i) * vstride;
    Float3 v;
    if (fast_xyz) {
      std::memcpy(&v.x, q + xyz_off[0], 4), std::memcpy(&v.y, q + xyz_off[1], 4), std::memcpy(&v.z, q + xyz_off[2], 4);
    } else {
      v = {float(scalar(q + xyz_off[0], xyz_type[0], swap)), float(scalar(q + xyz_off[1], xyz_type[1], swap)),
           float(scalar(q + xyz_off[2], xyz_type[2], swap))};
    }
    return v;
  };

  ImportStats st;
  TriangleEmitter out(xf, fn, st, batch);
  if (face.count > std::uint64_t(end - fbase)) throw InputError(path, "face", "file truncated inside the face data");
  map.advise_sequential();
  p = fbase;
  std::vector<std::int64_t> idx;
  std::vector<Role> roles;
  for (auto& prop : face.props) roles.push_back(role(prop));
  // Keep the resident set bounded on files larger than memory: every 64 MiB of faces,
  // drop the mapped pages read so far (faces and vertices; vertices fault back in when
  // referenced again, which for generated meshes is rare since pieces are local).
  const unsigned char* dropped = fbase;
  auto truncated = [&]() { return InputError(path, "face", "file truncated inside the face data"); };
  for (std::uint64_t f = 0; f < face.count; ++f) {
    if (std::size_t(p - dropped) > kDropEvery) {
      map.release(dropped, p);
      map.release(vbase, vbase + nv * vstride);
      dropped = p;
    }
    std::uint32_t material = 0;
    idx.clear();
    for (std::size_t k = 0; k < face.props.size(); ++k) {
      const Property& prop = face.props[k];
      if (prop.list) {
        if (std::size_t(end - p) < type_size(prop.count_type)) throw truncated();
        const auto n = static_cast<std::int64_t>(scalar(p, prop.count_type, swap));
        p += type_size(prop.count_type);
        const std::size_t is = type_size(prop.type);
        if (n < 0 || std::size_t(n) * is > std::size_t(end - p)) throw truncated();
        if (roles[k] != Role::indices) {
          p += std::size_t(n) * is;
          continue;
        }
        for (std::int64_t i = 0; i < n; ++i, p += is) idx.push_back(static_cast<std::int64_t>(scalar(p, prop.type, swap)));
      } else {
        if (std::size_t(end - p) < type_size(prop.type)) throw truncated();
        if (roles[k] == Role::material) material = binary_material(path, f, scalar(p, prop.type, swap));
        p += type_size(prop.type);
      }
    }
    if (idx.size() < 3) {
      out.skip();
      continue;
    }
    const Float3 a = position(idx[0]);
    Float3 b = position(idx[1]);
    for (std::size_t k = 2; k < idx.size(); ++k) {
      const Float3 c = position(idx[k]);
      out.emit(a, b, c, material);
      b = c;
    }
  }
  out.flush();
  return st;
}

// ---------------------------------------------------------------------------------------
// ASCII

// A count no file of this size could hold is an error before any spill space is reserved
// for it ("0 0 0\n": each value takes at least two bytes).
void check_counts_fit(const std::string& path, const Header& h) {
  std::error_code ec;
  const std::uint64_t size = std::filesystem::file_size(path, ec);
  std::uint64_t least = 0;
  for (auto& e : h.elements) {
    const std::uint64_t per = 2 * std::max<std::uint64_t>(e.props.size(), 1);
    if (e.count > (size + 1) / per) least = std::uint64_t(-1);
    else least += e.count * per;
    if (!ec && least > size + 1)
      throw InputError(path, "header.element", "'" + e.name + "' count " + std::to_string(e.count) +
                                                   " is more than a file of " + std::to_string(size) +
                                                   " bytes can hold (bad count or truncated)");
  }
}

// Steps over a list property: its length, then that many words.
bool skip_list(Tokens& t) {
  std::int64_t n = 0;
  bool ok = t.integer(n) && n >= 0;
  for (std::int64_t k = 0; ok && k < n; ++k) ok = !t.word().empty();
  return ok;
}

// An ASCII PLY body: vertex lines, then face lines (each polygon emitted as a fan), in the
// order the header declares the elements.
class AsciiPly {
 public:
  AsciiPly(const std::string& path, const Header& h, const Affine& xf, const TriangleBatchFn& fn, std::size_t batch)
      : path_(path), h_(h), vertex_(h.elements[std::size_t(h.vertex)]), face_(h.elements[std::size_t(h.face)]),
        out_(xf, fn, st_, batch) {
    for (auto& prop : vertex_.props) vroles_.push_back(role(prop));
    for (auto& prop : face_.props) froles_.push_back(role(prop));
  }

  ImportStats run() {
    check_counts_fit(path_, h_);
    verts_.reserve(std::size_t(vertex_.count));
    if (h_.vertex < h_.face) {
      pass(true, true);
    } else {
      pass(true, false);
      pass(false, true);
    }
    out_.flush();
    return st_;
  }

 private:
  InputError bad(const LineReader& r, std::string_view line, const char* what, std::uint64_t i, const Property& prop) const {
    return InputError(path_, r.where(), std::string(what) + " " + std::to_string(i) + ": bad or missing value for property '" +
                                            prop.name + "' in " + quote_token(line));
  }

  void read_vertex(const LineReader& r, std::string_view line, std::uint64_t i) {
    Tokens t(line);
    Float3 v;
    for (std::size_t k = 0; k < vroles_.size(); ++k) {
      bool ok;
      switch (vroles_[k]) {
        case Role::x: ok = t.number(v.x); break;
        case Role::y: ok = t.number(v.y); break;
        case Role::z: ok = t.number(v.z); break;
        case Role::skip_list: ok = skip_list(t); break;
        default: ok = !t.word().empty(); break;
      }
      if (!ok) throw bad(r, line, "vertex", i, vertex_.props[k]);
    }
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
      throw InputError(path_, r.where(), "vertex " + std::to_string(i) + ": non-finite coordinate");
    verts_.push_back(v);
  }

  // The vertex index list of face f, each index checked against the vertex count.
  bool read_indices(const LineReader& r, Tokens& t, std::uint64_t f) {
    std::int64_t n = 0;
    bool ok = t.integer(n) && n >= 0;
    for (std::int64_t j = 0; ok && j < n; ++j) {
      std::int64_t i;
      ok = t.integer(i);
      if (ok && (i < 0 || std::uint64_t(i) >= vertex_.count))
        throw InputError(path_, r.where(), "face " + std::to_string(f) + ": vertex index " + std::to_string(i) +
                                               " out of range (" + std::to_string(vertex_.count) + " vertices)");
      if (ok) idx_.push_back(std::uint64_t(i));
    }
    return ok;
  }

  void read_face(const LineReader& r, std::string_view line, std::uint64_t f) {
    Tokens t(line);
    std::uint32_t material = 0;
    idx_.clear();
    for (std::size_t k = 0; k < froles_.size(); ++k) {
      bool ok = true;
      switch (froles_[k]) {
        case Role::indices: ok = read_indices(r, t, f); break;
        case Role::material: {
          float m = 0;
          ok = t.number(m) && material_slot(m, material);
          break;
        }
        case Role::skip_list: ok = skip_list(t); break;
        default: ok = !t.word().empty(); break;
      }
      if (!ok) throw bad(r, line, "face", f, face_.props[k]);
    }
    if (idx_.size() < 3) {
      out_.skip();
      return;
    }
    const Float3 a = verts_[idx_[0]];
    Float3 b = verts_[idx_[1]];
    for (std::size_t k = 2; k < idx_.size(); ++k) {
      const Float3 c = verts_[idx_[k]];
      out_.emit(a, b, c, material);
      b = c;
    }
  }

  // One pass reads the elements in file order up to `last`, parsing vertices and/or
  // faces and stepping over every other line.
  void pass(bool vertices, bool faces) {
    LineReader r(path_, h_.bytes, h_.lines + 1);
    const int last = vertices && faces ? std::max(h_.vertex, h_.face) : vertices ? h_.vertex : h_.face;
    std::string_view line;
    std::uint64_t bytes = 0;
    for (int k = 0; k <= last; ++k) {
      const Element& e = h_.elements[std::size_t(k)];
      const bool v = vertices && k == h_.vertex, fc = faces && k == h_.face;
      for (std::uint64_t i = 0; i < e.count; ++i) {
        if (!r.next(line))
          throw InputError(path_, e.name, "the header says " + std::to_string(e.count) + " " + e.name +
                                              " elements but the file ends after " + std::to_string(i) + " (truncated)");
        if (v) read_vertex(r, line, i);
        if (fc) {
          read_face(r, line, i);
          bytes += line.size() + 1;
          if (bytes > kDropEvery) verts_.drop_resident(), bytes = 0;
        }
      }
    }
  }

  const std::string& path_;
  const Header& h_;
  const Element& vertex_;
  const Element& face_;
  SpillArray<Float3> verts_;
  ImportStats st_;
  TriangleEmitter out_;
  std::vector<std::uint64_t> idx_;
  std::vector<Role> vroles_, froles_;
};

ImportStats stream_ascii(const std::string& path, const Header& h, const Affine& xf, const TriangleBatchFn& fn,
                         std::size_t batch) {
  return AsciiPly(path, h, xf, fn, batch).run();
}

}  // namespace

PlyHeaderInfo read_ply_header(const std::string& path) { return parse_header(path).info; }

ImportStats stream_ply(const std::string& path, const Affine& xf, const TriangleBatchFn& fn, std::size_t batch) {
  const Header h = parse_header(path);
  if (!h.info.streamable)
    throw InputError(path, "header", "not a PLY with vertex x,y,z and one integer face index list");
  return h.info.binary ? stream_binary(path, h, xf, fn, batch) : stream_ascii(path, h, xf, fn, batch);
}

}  // namespace rayline::scene
