#include "render/scene/ply_reader.hpp"

#include <bit>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <sstream>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

#include "sched/error.hpp"

namespace rayline::scene {
namespace {

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

struct Property {
  std::string name;
  Type type = Type::invalid;
  bool list = false;
  Type count_type = Type::invalid;
};
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

struct Header {
  PlyHeaderInfo info;
  std::vector<Element> elements;
  std::size_t bytes = 0;
};

Header parse_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open mesh file");
  Header h;
  std::string line;
  if (!std::getline(in, line) || line.substr(0, 3) != "ply") throw InputError(path, "header", "not a PLY file");
  bool ended = false;
  std::size_t bytes = line.size() + 1;
  while (std::getline(in, line)) {
    bytes += line.size() + 1;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string kw;
    ls >> kw;
    if (kw == "format") {
      std::string f;
      ls >> f;
      h.info.binary = f != "ascii";
      h.info.big_endian = f == "binary_big_endian";
      if (f != "ascii" && f != "binary_little_endian" && f != "binary_big_endian")
        throw InputError(path, "header.format", "unknown PLY format '" + f + "'");
    } else if (kw == "element") {
      Element e;
      ls >> e.name >> e.count;
      if (!ls) throw InputError(path, "header.element", "malformed element line '" + line + "'");
      h.elements.push_back(e);
    } else if (kw == "property") {
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
      h.elements.back().props.push_back(p);
    } else if (kw == "end_header") {
      ended = true;
      break;
    }
  }
  if (!ended) throw InputError(path, "header", "no end_header (truncated or not a PLY file)");
  h.bytes = bytes;
  for (auto& e : h.elements) {
    if (e.name == "vertex") h.info.vertices = e.count;
    if (e.name == "face") h.info.faces = e.count;
  }
  // Streamable: binary; every element before `face` has fixed size; vertex has x, y, z;
  // face has exactly one list (vertex_indices / vertex_index) of integer type.
  bool ok = h.info.binary;
  bool seen_face = false, seen_vertex = false;
  for (auto& e : h.elements) {
    if (seen_face) break;
    if (e.name == "face") {
      seen_face = true;
      int lists = 0;
      for (auto& p : e.props) {
        if (!p.list) continue;
        ++lists;
        ok = ok && (p.name == "vertex_indices" || p.name == "vertex_index") && p.type != Type::f32 &&
             p.type != Type::f64;
      }
      ok = ok && lists == 1;
    } else {
      ok = ok && e.fixed();
      if (e.name == "vertex") {
        seen_vertex = true;
        int xyz = 0;
        for (auto& p : e.props) xyz += p.name == "x" || p.name == "y" || p.name == "z";
        ok = ok && xyz == 3;
      }
    }
  }
  h.info.streamable = ok && seen_face && seen_vertex;
  return h;
}

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

struct Mapping {
  const unsigned char* data = nullptr;
  std::size_t size = 0;
  Mapping(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY);
    if (fd < 0) throw InputError(path, "", "cannot open mesh file");
    struct stat st{};
    ::fstat(fd, &st);
    size = static_cast<std::size_t>(st.st_size);
    if (size > 0) {
      void* m = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
      if (m == MAP_FAILED) {
        ::close(fd);
        throw InputError(path, "", "cannot map mesh file");
      }
      data = static_cast<const unsigned char*>(m);
    }
    ::close(fd);
  }
  ~Mapping() {
    if (data) ::munmap(const_cast<unsigned char*>(data), size);
  }
};

}  // namespace

PlyHeaderInfo read_ply_header(const std::string& path) { return parse_header(path).info; }

ImportStats stream_ply(const std::string& path, const Affine& xf, const TriangleBatchFn& fn, std::size_t batch) {
  const Header h = parse_header(path);
  if (!h.info.streamable)
    throw InputError(path, "header", "not a binary PLY with vertex x,y,z and one face index list");
  const bool swap = h.info.big_endian != (std::endian::native == std::endian::big);
  const Mapping map(path);
  const unsigned char* end = map.data + map.size;

  // Locate the vertex and face sections (fixed-size elements before the face element).
  std::size_t offset = h.bytes;
  const Element* vertex = nullptr;
  const Element* face = nullptr;
  std::size_t vertex_offset = 0, face_offset = 0;
  for (auto& e : h.elements) {
    if (e.name == "face") {
      face = &e, face_offset = offset;
      break;
    }
    if (e.name == "vertex") vertex = &e, vertex_offset = offset;
    offset += e.stride() * e.count;
  }
  if (offset > map.size) throw InputError(path, "vertex", "file truncated inside the vertex data");
  const std::size_t vstride = vertex->stride();
  std::size_t xyz_off[3] = {0, 0, 0};
  Type xyz_type[3] = {Type::f32, Type::f32, Type::f32};
  {
    std::size_t o = 0;
    for (auto& p : vertex->props) {
      const int axis = p.name == "x" ? 0 : p.name == "y" ? 1 : p.name == "z" ? 2 : -1;
      if (axis >= 0) xyz_off[axis] = o, xyz_type[axis] = p.type;
      o += type_size(p.type);
    }
  }
  const bool fast_xyz = !swap && xyz_type[0] == Type::f32 && xyz_type[1] == Type::f32 && xyz_type[2] == Type::f32;
  const unsigned char* vbase = map.data + vertex_offset;
  const std::uint64_t nv = vertex->count;
  auto position = [&](std::int64_t i) -> Float3 {
    if (i < 0 || std::uint64_t(i) >= nv)
      throw InputError(path, "face.vertex_indices", "index " + std::to_string(i) + " out of range (" +
                                                        std::to_string(nv) + " vertices)");
    const unsigned char* p = vbase + std::size_t(i) * vstride;
    Float3 v;
    if (fast_xyz) {
      std::memcpy(&v.x, p + xyz_off[0], 4), std::memcpy(&v.y, p + xyz_off[1], 4), std::memcpy(&v.z, p + xyz_off[2], 4);
    } else {
      v = {float(scalar(p + xyz_off[0], xyz_type[0], swap)), float(scalar(p + xyz_off[1], xyz_type[1], swap)),
           float(scalar(p + xyz_off[2], xyz_type[2], swap))};
    }
    return v;
  };

  ImportStats st;
  const bool identity = xf.is_identity();
  std::vector<Triangle> buf;
  buf.reserve(batch);
  auto emit = [&](Float3 a, Float3 b, Float3 c, std::uint32_t m) {
    if (!identity) a = xf.point(a), b = xf.point(b), c = xf.point(c);
    st.bounds.extend(a), st.bounds.extend(b), st.bounds.extend(c);
    buf.push_back({a, b, c, m});
    ++st.triangles;
    if (buf.size() == batch) fn(std::span<const Triangle>(buf)), buf.clear();
  };
  if (face_offset + face->count > map.size && face->count > 0)
    throw InputError(path, "face", "file truncated inside the face data");
  ::madvise(const_cast<unsigned char*>(map.data), map.size, MADV_SEQUENTIAL);
  const unsigned char* p = map.data + face_offset;
  std::vector<std::int64_t> idx;
  // Keep the resident set bounded on files larger than memory: every 64 MiB of faces,
  // drop the mapped pages read so far (faces and vertices; vertices fault back in when
  // referenced again, which for generated meshes is rare since pieces are local).
  const std::size_t page = std::size_t(::sysconf(_SC_PAGESIZE));
  auto page_down = [&](const unsigned char* q) {
    return const_cast<unsigned char*>(map.data) + (std::size_t(q - map.data) / page) * page;
  };
  const unsigned char* dropped = page_down(map.data + face_offset);
  for (std::uint64_t f = 0; f < face->count; ++f) {
    if (std::size_t(p - dropped) > (64u << 20)) {
      unsigned char* to = page_down(p);
      ::madvise(const_cast<unsigned char*>(dropped), std::size_t(to - dropped), MADV_DONTNEED);
      unsigned char* v0 = page_down(vbase);
      ::madvise(v0, std::size_t(page_down(vbase + nv * vstride) - v0), MADV_DONTNEED);
      dropped = to;
    }
    std::uint32_t material = 0;
    idx.clear();
    for (auto& prop : face->props) {
      if (prop.list) {
        if (p + type_size(prop.count_type) > end) throw InputError(path, "face", "file truncated inside the face data");
        const auto n = static_cast<std::int64_t>(scalar(p, prop.count_type, swap));
        p += type_size(prop.count_type);
        const std::size_t is = type_size(prop.type);
        if (n < 0 || p + std::size_t(n) * is > end) throw InputError(path, "face", "file truncated inside the face data");
        for (std::int64_t k = 0; k < n; ++k, p += is) idx.push_back(static_cast<std::int64_t>(scalar(p, prop.type, swap)));
      } else {
        if (p + type_size(prop.type) > end) throw InputError(path, "face", "file truncated inside the face data");
        if (prop.name == "material_index") material = static_cast<std::uint32_t>(scalar(p, prop.type, swap));
        p += type_size(prop.type);
      }
    }
    if (idx.size() < 3) {
      ++st.skipped_primitives;
      continue;
    }
    const Float3 a = position(idx[0]);
    Float3 b = position(idx[1]);
    for (std::size_t k = 2; k < idx.size(); ++k) {
      const Float3 c = position(idx[k]);
      emit(a, b, c, material);
      b = c;
    }
  }
  if (!buf.empty()) fn(std::span<const Triangle>(buf));
  return st;
}

}  // namespace rayline::scene
