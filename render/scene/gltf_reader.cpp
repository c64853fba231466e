#include "render/scene/gltf_reader.hpp"

#include "render/scene/little_endian.hpp"

#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <vector>

#include "render/scene/mapped_file.hpp"
#include "render/scene/triangle_emitter.hpp"
#include "common/error.hpp"
#include "common/json_fields.hpp"

namespace rayline::scene {
namespace {

using json = nlohmann::json;

// Mapped buffer pages are dropped from the resident set after this many triangles.
constexpr std::uint64_t kDropEveryTriangles = 1u << 20;

template <class T>
T le(const unsigned char* p) {
  return get_le<T>(p);
}

std::string at(const std::string& base, std::size_t i) { return base + "[" + std::to_string(i) + "]"; }

// Double-precision affine (3 rows of 4) for composing node transforms.
using Mat = std::array<std::array<double, 4>, 3>;
constexpr Mat kIdentity = {{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}}};
Mat mul(const Mat& a, const Mat& b) {
  Mat r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) {
      double s = j == 3 ? a[i][3] : 0.0;
      for (int k = 0; k < 3; ++k) s += a[i][k] * b[k][j];
      r[i][j] = s;
    }
  return r;
}
Affine to_affine(const Mat& m) {
  Affine a;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) a.m[i][j] = float(m[i][j]);
  return a;
}

std::vector<unsigned char> decode_base64(std::string_view s, bool& ok) {
  static const auto table = [] {
    std::array<int, 256> t{};
    t.fill(-1);
    const char* a = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (int i = 0; i < 64; ++i) t[static_cast<unsigned char>(a[i])] = i;
    t['-'] = 62, t['_'] = 63;  // URL-safe alphabet
    return t;
  }();
  std::vector<unsigned char> out;
  out.reserve(s.size() / 4 * 3);
  unsigned acc = 0;
  int bits = 0;
  ok = true;
  for (char c : s) {
    if (c == '=') break;
    if (c == '\n' || c == '\r' || c == ' ') continue;
    const int v = table[static_cast<unsigned char>(c)];
    if (v < 0) {
      ok = false;
      return {};
    }
    acc = (acc << 6) | unsigned(v), bits += 6;
    if (bits >= 8) bits -= 8, out.push_back(static_cast<unsigned char>((acc >> bits) & 0xff));
  }
  return out;
}

std::string percent_decode(const std::string& s) {
  std::string r;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
      r += char(std::stoi(s.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      r += s[i];
    }
  }
  return r;
}

// One accessor, validated against its buffer view and buffer.
struct View {
  const unsigned char* base = nullptr;  // nullptr: no bufferView, every value is 0
  std::size_t stride = 0;
  std::uint64_t count = 0;
  int component = 0;  // glTF componentType
  int width = 0;      // components per element
  bool normalized = false;
  std::string field;  // "accessors[i]"

  Float3 vec3(std::uint64_t i) const {
    if (!base) return {};
    const unsigned char* p = base + i * stride;
    if (component == 5126) return {le<float>(p), le<float>(p + 4), le<float>(p + 8)};
    Float3 v;
    for (int c = 0; c < 3; ++c) v[c] = component_value(p, c);
    return v;
  }
  std::uint32_t index(std::uint64_t i) const {
    if (!base) return 0;
    const unsigned char* p = base + i * stride;
    switch (component) {
      case 5121: return *p;
      case 5123: return le<std::uint16_t>(p);
      default: return le<std::uint32_t>(p);
    }
  }

 private:
  float component_value(const unsigned char* p, int c) const {
    switch (component) {
      case 5120: { const float v = float(static_cast<std::int8_t>(p[c])); return normalized ? std::max(v / 127.0f, -1.0f) : v; }
      case 5121: { const float v = float(p[c]); return normalized ? v / 255.0f : v; }
      case 5122: { const float v = float(le<std::int16_t>(p + 2 * c)); return normalized ? std::max(v / 32767.0f, -1.0f) : v; }
      case 5123: { const float v = float(le<std::uint16_t>(p + 2 * c)); return normalized ? v / 65535.0f : v; }
      case 5125: return float(le<std::uint32_t>(p + 4 * c));
      default: return le<float>(p + 4 * c);
    }
  }
};

struct Primitive {
  bool has_position = false;
  View position;
  bool indexed = false;
  View indices;
  int mode = 4;
  std::uint32_t material = 0;
  std::string field;  // "meshes[m].primitives[p]"
};

struct Buffer {
  const unsigned char* data = nullptr;
  std::size_t size = 0;
  bool loaded = false;
};

class Gltf {
 public:
  Gltf(const std::string& path, const Affine& xf, const TriangleBatchFn& fn, std::size_t batch)
      : path_(path), xf_(xf), fn_(fn), batch_(batch) {}

  std::optional<ImportStats> run() {
    if (!load_document()) return std::nullopt;
    try {
      return stream();
    } catch (const json::exception& e) {
      fail("json", std::string("unexpected JSON value: ") + e.what());
    }
  }

  // The files buffers[].uri and images[].uri name (not data: URIs), beside the document.
  std::vector<std::string> external_files() {
    std::vector<std::string> out;
    try {
      if (!load_document()) return out;
      for (const char* key : {"buffers", "images"})
        for (const json& b : array(doc_, key, key))
          if (b.is_object() && b.contains("uri") && b["uri"].is_string()) {
            const std::string uri = b["uri"].get<std::string>();
            if (uri.rfind("data:", 0) != 0)
              out.push_back((std::filesystem::path(path_).parent_path() / percent_decode(uri)).string());
          }
    } catch (const std::exception&) {
      // A damaged document names what it can; importing it reports the damage.
    }
    return out;
  }

 private:
  [[noreturn]] void fail(const std::string& field, const std::string& msg) const { throw InputError(path_, field, msg); }

  // ---- document -----------------------------------------------------------------------

  bool load_document() {
    file_ = std::make_unique<MappedFile>(path_);
    const unsigned char* d = file_->data();
    const std::size_t n = file_->size();
    const unsigned char* json_begin = d;
    std::size_t json_size = n;
    if (n >= 4 && std::memcmp(d, "glTF", 4) == 0) {
      if (n < 20) fail("glb header", "truncated GLB: " + std::to_string(n) + " bytes, the header and first chunk need 20");
      const std::uint32_t version = le<std::uint32_t>(d + 4), length = le<std::uint32_t>(d + 8);
      if (version == 1) return false;  // glTF 1.0 binary: assimp
      if (version != 2) fail("glb header", "unsupported GLB version " + std::to_string(version));
      if (length > n)
        fail("glb header", "header says " + std::to_string(length) + " bytes but the file has " + std::to_string(n) +
                               " (truncated)");
      const std::uint32_t jlen = le<std::uint32_t>(d + 12), jtype = le<std::uint32_t>(d + 16);
      if (jtype != 0x4E4F534A) fail("glb chunk[0]", "first chunk is not JSON");
      if (std::uint64_t(20) + jlen > length) fail("glb chunk[0]", "JSON chunk runs past the end of the file (truncated)");
      json_begin = d + 20, json_size = jlen;
      const std::uint64_t bin_at = std::uint64_t(20) + jlen;
      if (bin_at + 8 <= length) {
        const std::uint32_t blen = le<std::uint32_t>(d + bin_at), btype = le<std::uint32_t>(d + bin_at + 4);
        if (btype == 0x004E4942) {
          if (bin_at + 8 + blen > length) fail("glb chunk[1]", "BIN chunk runs past the end of the file (truncated)");
          glb_bin_ = {d + bin_at + 8, blen, true};
          has_glb_bin_ = true;
        }
      }
    }
    try {
      // Depth limited while parsing (kMaxJsonDepth, common/json_fields.hpp).
      doc_ = json::parse(json_begin, json_begin + json_size, [this](int depth, json::parse_event_t event, json&) {
        if ((event == json::parse_event_t::object_start || event == json::parse_event_t::array_start) &&
            depth >= kMaxJsonDepth)
          fail("json", "objects and arrays nested more than " + std::to_string(kMaxJsonDepth) + " levels deep");
        return true;
      });
    } catch (const json::exception& e) {  // parse_error, and out_of_range for "1e400"
      fail("json", e.what());
    }
    if (!doc_.is_object()) fail("json", "top level is not an object");
    if (!has_glb_bin_) file_->release();  // the JSON text is parsed; keep nothing of it resident
    if (doc_.contains("asset") && doc_["asset"].is_object() && doc_["asset"].contains("version")) {
      const json& v = doc_["asset"]["version"];
      if (!v.is_string()) fail("asset.version", "not a string");
      const std::string s = v.get<std::string>();
      if (!s.empty() && s[0] == '1') return false;  // glTF 1.0: assimp
      if (s.empty() || s[0] != '2') fail("asset.version", "unsupported glTF version '" + s + "'");
    }
    for (const json& e : array(doc_, "extensionsRequired", "extensionsRequired"))
      if (e.is_string() && (e == "KHR_draco_mesh_compression" || e == "EXT_meshopt_compression")) return false;
    buffers_.resize(array(doc_, "buffers", "buffers").size());
    return true;
  }

  const json& array(const json& obj, const char* key, const std::string& field) const {
    static const json empty = json::array();
    if (!obj.contains(key)) return empty;
    const json& a = obj[key];
    if (!a.is_array()) fail(field, "not an array");
    return a;
  }
  const json& object(const json& arr, std::size_t i, const std::string& field) const {
    if (i >= arr.size()) fail(field, "index " + std::to_string(i) + " out of range (" + std::to_string(arr.size()) + ")");
    if (!arr[i].is_object()) fail(field, "not an object");
    return arr[i];
  }
  std::uint64_t uint(const json& obj, const char* key, const std::string& field, std::optional<std::uint64_t> def = {}) const {
    const std::string f = field.empty() ? std::string(key) : field + "." + key;
    if (!obj.contains(key)) {
      if (def) return *def;
      fail(f, "missing");
    }
    const json& v = obj[key];
    if (!v.is_number_unsigned() && !(v.is_number_integer() && v.get<std::int64_t>() >= 0))
      fail(f, "expected a non-negative integer, got " + v.dump());
    return v.get<std::uint64_t>();
  }

  // ---- buffers and accessors -----------------------------------------------------------

  const Buffer& buffer(std::size_t i) {
    const std::string field = at("buffers", i);
    const json& b = object(array(doc_, "buffers", "buffers"), i, field);
    Buffer& buf = buffers_[i];
    if (buf.loaded) return buf;
    const std::uint64_t length = uint(b, "byteLength", field);
    if (!b.contains("uri")) {
      if (i != 0 || !has_glb_bin_) fail(field + ".uri", "missing (only buffer 0 of a .glb may omit it)");
      buf = glb_bin_;
    } else {
      if (!b["uri"].is_string()) fail(field + ".uri", "not a string");
      const std::string uri = b["uri"].get<std::string>();
      if (uri.rfind("data:", 0) == 0) {
        const std::size_t comma = uri.find(',');
        if (comma == std::string::npos || uri.substr(0, comma).find(";base64") == std::string::npos)
          fail(field + ".uri", "only base64 data URIs are supported");
        bool ok = false;
        decoded_.push_back(decode_base64(std::string_view(uri).substr(comma + 1), ok));
        if (!ok) fail(field + ".uri", "malformed base64 data");
        buf = {decoded_.back().data(), decoded_.back().size(), true};
      } else {
        const std::filesystem::path file = std::filesystem::path(path_).parent_path() / percent_decode(uri);
        try {
          mapped_.push_back(std::make_unique<MappedFile>(file.string()));
        } catch (const InputError& e) {
          fail(field + ".uri", "cannot read '" + file.string() + "': " + e.what());
        }
        buf = {mapped_.back()->data(), mapped_.back()->size(), true};
      }
    }
    if (buf.size < length)
      fail(field, "byteLength is " + std::to_string(length) + " but the data has " + std::to_string(buf.size) +
                      " bytes (truncated)");
    buf.size = std::size_t(length);
    return buf;
  }

  // Validates accessor `i` for `use` (VEC3 positions or SCALAR indices).
  View accessor(std::size_t i, bool indices, bool& sparse) {
    const std::string field = at("accessors", i);
    const json& a = object(array(doc_, "accessors", "accessors"), i, field);
    View v;
    v.field = field;
    v.count = uint(a, "count", field);
    v.component = int(uint(a, "componentType", field));
    v.normalized = a.contains("normalized") && a["normalized"].is_boolean() && a["normalized"].get<bool>();
    if (!a.contains("type") || !a["type"].is_string()) fail(field + ".type", "missing or not a string");
    const std::string type = a["type"].get<std::string>();
    std::size_t csize = 0;
    switch (v.component) {
      case 5120: case 5121: csize = 1; break;
      case 5122: case 5123: csize = 2; break;
      case 5125: case 5126: csize = 4; break;
      default: fail(field + ".componentType", "unknown component type " + std::to_string(v.component));
    }
    if (indices) {
      if (type != "SCALAR") fail(field + ".type", "indices must be SCALAR, not " + type);
      if (v.component != 5121 && v.component != 5123 && v.component != 5125)
        fail(field + ".componentType", "indices must be unsigned byte, short or int");
      v.width = 1;
    } else {
      if (type != "VEC3") fail(field + ".type", "POSITION must be VEC3, not " + type);
      if (v.component == 5125) fail(field + ".componentType", "POSITION cannot be unsigned int");
      v.width = 3;
    }
    // Sparse accessors, and accessors without a bufferView (all zeros, usually the base
    // of a sparse one; their count is not bounded by any data), go to assimp.
    if (a.contains("sparse") || !a.contains("bufferView")) sparse = true;
    const std::size_t elem = csize * std::size_t(v.width);
    if (!a.contains("bufferView")) return v;
    const std::size_t vi = std::size_t(uint(a, "bufferView", field));
    const std::string vfield = at("bufferViews", vi);
    const json& bv = object(array(doc_, "bufferViews", "bufferViews"), vi, field + ".bufferView");
    const std::uint64_t voff = uint(bv, "byteOffset", vfield, 0), vlen = uint(bv, "byteLength", vfield);
    const std::uint64_t stride = uint(bv, "byteStride", vfield, 0);
    if (stride != 0 && stride < elem) fail(vfield + ".byteStride", std::to_string(stride) + " is less than the element size " + std::to_string(elem));
    v.stride = stride ? std::size_t(stride) : elem;
    const Buffer& buf = buffer(std::size_t(uint(bv, "buffer", vfield)));
    if (voff > buf.size || vlen > buf.size - voff)
      fail(vfield, "bytes [" + std::to_string(voff) + ", " + std::to_string(voff + vlen) + ") outside its buffer of " +
                       std::to_string(buf.size) + " bytes");
    const std::uint64_t aoff = uint(a, "byteOffset", field, 0);
    if (v.count > 0) {
      const long double need = (long double)aoff + (long double)v.stride * (long double)(v.count - 1) + (long double)elem;
      if (need > (long double)vlen)
        fail(field, std::to_string(v.count) + " elements from byte " + std::to_string(aoff) + " need " +
                        std::to_string(std::uint64_t(need)) + " bytes but " + vfield + " has " + std::to_string(vlen));
    }
    v.base = buf.data + voff + aoff;
    return v;
  }

  const Primitive& primitive(std::size_t m, std::size_t p, bool& sparse) {
    auto key = std::make_pair(m, p);
    if (auto it = prims_.find(key); it != prims_.end()) return it->second;
    Primitive pr;
    pr.field = at("meshes", m) + "." + at("primitives", p);
    const json& mesh = object(array(doc_, "meshes", "meshes"), m, at("meshes", m));
    const json& prim = object(array(mesh, "primitives", at("meshes", m) + ".primitives"), p, pr.field);
    pr.mode = int(uint(prim, "mode", pr.field, 4));
    if (pr.mode > 6) fail(pr.field + ".mode", "unknown primitive mode " + std::to_string(pr.mode));
    pr.material = std::uint32_t(uint(prim, "material", pr.field, 0));
    if (!prim.contains("attributes") || !prim["attributes"].is_object()) fail(pr.field + ".attributes", "missing");
    const json& attrs = prim["attributes"];
    if (attrs.contains("POSITION")) {
      pr.has_position = true;
      pr.position = accessor(std::size_t(uint(attrs, "POSITION", pr.field + ".attributes")), false, sparse);
    }
    if (prim.contains("indices")) {
      pr.indexed = true;
      pr.indices = accessor(std::size_t(uint(prim, "indices", pr.field)), true, sparse);
    }
    return prims_.emplace(key, std::move(pr)).first->second;
  }

  // ---- scene graph ---------------------------------------------------------------------

  Mat local_transform(const json& node, const std::string& field) const {
    auto numbers = [&](const char* key, std::size_t n) {
      const json& a = node[key];
      if (!a.is_array() || a.size() != n) fail(field + "." + key, "expected " + std::to_string(n) + " numbers");
      std::vector<double> v;
      for (const json& x : a) {
        if (!x.is_number()) fail(field + "." + key, "expected numbers");
        v.push_back(x.get<double>());
      }
      return v;
    };
    Mat m = kIdentity;
    if (node.contains("matrix")) {
      const auto c = numbers("matrix", 16);  // column-major 4x4
      for (int r = 0; r < 3; ++r)
        for (int col = 0; col < 4; ++col) m[r][col] = c[std::size_t(col * 4 + r)];
      return m;
    }
    std::vector<double> t = {0, 0, 0}, q = {0, 0, 0, 1}, s = {1, 1, 1};
    if (node.contains("translation")) t = numbers("translation", 3);
    if (node.contains("rotation")) q = numbers("rotation", 4);
    if (node.contains("scale")) s = numbers("scale", 3);
    const double qn = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (qn > 0)
      for (double& x : q) x /= qn;
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                            {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                            {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) m[i][j] = r[i][j] * s[std::size_t(j)];
      m[i][3] = t[std::size_t(i)];
    }
    return m;
  }

  struct Instance {
    std::size_t mesh;
    Mat world;
    std::string field;  // where the mesh index came from
  };

  std::vector<Instance> instances() const {
    const json& nodes = array(doc_, "nodes", "nodes");
    const json& scenes = array(doc_, "scenes", "scenes");
    std::vector<std::size_t> roots;
    std::string roots_field;
    if (!scenes.empty()) {
      const std::size_t si = std::size_t(uint(doc_, "scene", "", 0));
      roots_field = at("scenes", si) + ".nodes";
      const json& sc = object(scenes, si, doc_.contains("scene") ? "scene" : "scenes");
      for (const json& n : array(sc, "nodes", roots_field)) {
        if (!n.is_number_unsigned()) fail(roots_field, "expected node indices");
        roots.push_back(n.get<std::size_t>());
      }
    } else if (!nodes.empty()) {  // no scene: every node that is nobody's child
      roots_field = "nodes";
      std::vector<bool> child(nodes.size(), false);
      for (std::size_t i = 0; i < nodes.size(); ++i)
        for (const json& c : array(object(nodes, i, at("nodes", i)), "children", at("nodes", i) + ".children"))
          if (c.is_number_unsigned() && c.get<std::size_t>() < nodes.size()) child[c.get<std::size_t>()] = true;
      for (std::size_t i = 0; i < nodes.size(); ++i)
        if (!child[i]) roots.push_back(i);
    } else {  // no nodes at all: every mesh once, untransformed
      std::vector<Instance> r;
      for (std::size_t m = 0; m < array(doc_, "meshes", "meshes").size(); ++m) r.push_back({m, kIdentity, "meshes"});
      return r;
    }
    // The hierarchy must be a forest (glTF 2.0: at most one parent per node): a node
    // reached twice means a cycle or a shared child, either of which could blow up.
    std::vector<Instance> out;
    std::vector<bool> seen(nodes.size(), false);
    struct Item {
      std::size_t node;
      Mat parent;
      std::string field;  // the list it came from
    };
    std::vector<Item> stack;
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back({*it, kIdentity, roots_field});
    while (!stack.empty()) {
      const Item item = stack.back();
      stack.pop_back();
      const json& node = object(nodes, item.node, item.field);
      if (seen[item.node])
        fail(item.field, "node " + std::to_string(item.node) +
                             " is reached twice (a cycle, or a node with two parents)");
      seen[item.node] = true;
      const std::string field = at("nodes", item.node);
      const Mat world = mul(item.parent, local_transform(node, field));
      if (node.contains("mesh")) out.push_back({std::size_t(uint(node, "mesh", field)), world, field + ".mesh"});
      const json& children = array(node, "children", field + ".children");
      for (std::size_t c = children.size(); c-- > 0;) {
        if (!children[c].is_number_unsigned()) fail(field + ".children", "expected node indices");
        stack.push_back({children[c].get<std::size_t>(), world, field + ".children"});
      }
    }
    return out;
  }

  // ---- streaming -----------------------------------------------------------------------

  std::optional<ImportStats> stream() {
    const std::vector<Instance> inst = instances();
    // Validate every primitive that will be emitted before emitting any, so that an
    // unsupported feature can still go to assimp.
    bool sparse = false;
    for (const Instance& in : inst) {
      const json& mesh = object(array(doc_, "meshes", "meshes"), in.mesh, in.field);
      const std::size_t np = array(mesh, "primitives", at("meshes", in.mesh) + ".primitives").size();
      for (std::size_t p = 0; p < np; ++p) primitive(in.mesh, p, sparse);
    }
    if (sparse) return std::nullopt;

    ImportStats st;
    TriangleEmitter out({}, fn_, st, batch_);
    std::uint64_t next_drop = kDropEveryTriangles;
    for (const Instance& in : inst) {
      const Affine world = to_affine(mul(to_mat(xf_), in.world));
      const std::size_t np = array(array(doc_, "meshes", "meshes")[in.mesh], "primitives", "").size();
      for (std::size_t p = 0; p < np; ++p) {
        emit(prims_.at({in.mesh, p}), world, out);
        if (st.triangles >= next_drop) {
          for (auto& m : mapped_) m->release();
          if (has_glb_bin_) file_->release();
          next_drop = st.triangles + kDropEveryTriangles;
        }
      }
    }
    out.flush();
    return st;
  }

  static Mat to_mat(const Affine& a) {
    Mat m{};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j) m[i][j] = a.m[i][j];
    return m;
  }

  void emit(const Primitive& pr, const Affine& world, TriangleEmitter& out) const {
    if (!pr.has_position) {
      out.skip();
      return;
    }
    const std::uint64_t nv = pr.position.count;
    const std::uint64_t n = pr.indexed ? pr.indices.count : nv;
    auto vertex = [&](std::uint64_t k) {
      std::uint64_t i = k;
      if (pr.indexed) {
        i = pr.indices.index(k);
        if (i >= nv)
          fail(pr.field + ".indices", "index " + std::to_string(i) + " (element " + std::to_string(k) +
                                          ") out of range (" + std::to_string(nv) + " vertices)");
      }
      return world.point(pr.position.vec3(i));
    };
    switch (pr.mode) {
      case 0: out.skip(n); return;                       // POINTS
      case 1: out.skip(n / 2); return;                   // LINES
      case 2: out.skip(n >= 2 ? n : 0); return;          // LINE_LOOP
      case 3: out.skip(n >= 2 ? n - 1 : 0); return;      // LINE_STRIP
      case 4:                                            // TRIANGLES
        for (std::uint64_t t = 0; t + 3 <= n; t += 3) out.emit(vertex(t), vertex(t + 1), vertex(t + 2), pr.material);
        if (n % 3) out.skip();
        return;
      case 5:  // TRIANGLE_STRIP: p_i = {v_i, v_{i+1+i%2}, v_{i+2-i%2}}
        for (std::uint64_t t = 0; t + 2 < n; ++t)
          out.emit(vertex(t), vertex(t + 1 + t % 2), vertex(t + 2 - t % 2), pr.material);
        return;
      case 6: {  // TRIANGLE_FAN: p_i = {v_{i+1}, v_{i+2}, v_0}
        if (n < 3) return;
        const Float3 c = vertex(0);
        for (std::uint64_t t = 0; t + 2 < n; ++t) out.emit(vertex(t + 1), vertex(t + 2), c, pr.material);
        return;
      }
    }
  }

  const std::string& path_;
  Affine xf_;
  const TriangleBatchFn& fn_;
  std::size_t batch_;
  std::unique_ptr<MappedFile> file_;
  Buffer glb_bin_;
  bool has_glb_bin_ = false;
  json doc_;
  std::vector<Buffer> buffers_;
  std::vector<std::unique_ptr<MappedFile>> mapped_;
  std::vector<std::vector<unsigned char>> decoded_;
  std::map<std::pair<std::size_t, std::size_t>, Primitive> prims_;
};

}  // namespace

std::optional<ImportStats> stream_gltf(const std::string& path, const Affine& xf, const TriangleBatchFn& fn,
                                       std::size_t batch) {
  Gltf g(path, xf, fn, batch);
  return g.run();
}

std::vector<std::string> gltf_external_files(const std::string& path) {
  const TriangleBatchFn none;
  Gltf g(path, Affine{}, none, 1);
  return g.external_files();
}

}  // namespace rayline::scene
