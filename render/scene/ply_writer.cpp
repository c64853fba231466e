#include "render/scene/ply_writer.hpp"

#include <bit>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "common/error.hpp"

namespace rayline::scene {
namespace {

constexpr std::size_t kBufferBytes = 4u << 20;
constexpr std::uint64_t kMaxVertices = 0x7fffffffu;  // indices are PLY `int`

// Stores v little-endian at p; returns the next position.
template <class T>
char* put(char* p, T v) {
  if constexpr (std::endian::native == std::endian::big) {
    auto* b = reinterpret_cast<unsigned char*>(&v);
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  }
  std::memcpy(p, &v, sizeof(T));
  return p + sizeof(T);
}

void write_all(std::FILE* f, const std::vector<char>& buf, const std::string& path) {
  if (!buf.empty() && std::fwrite(buf.data(), 1, buf.size(), f) != buf.size())
    throw InputError(path, "", "write failed (disk full?)");
}

}  // namespace

PlyWriter::PlyWriter(std::string path, std::vector<std::string> comments)
    : path_(std::move(path)),
      tmp_(unfinished::fresh_temp_name(path_, "tmp")),
      faces_tmp_(unfinished::temp_name(path_, "tmp-faces")),
      comments_(std::move(comments)) {
  vf_ = std::fopen(tmp_.c_str(), "wb");
  if (!vf_) throw InputError(path_, "", "cannot open for writing");
  ff_ = std::fopen(faces_tmp_.c_str(), "wb+");
  if (!ff_) {
    std::fclose(vf_);
    std::remove(tmp_.c_str());
    throw InputError(path_, "", "cannot open temporary file for writing");
  }
  vbuf_.reserve(kBufferBytes + 4096);
  fbuf_.reserve(kBufferBytes + 4096);
  // Reserve room for the header with the widest counts plus a padding comment line.
  reserved_ = header(0).size() + 40 + 64;
  std::vector<char> zeros(reserved_, '\n');
  try {
    write_all(vf_, zeros, path_);
  } catch (...) {  // no destructor runs for a constructor that throws
    std::fclose(vf_);
    std::fclose(ff_);
    std::remove(tmp_.c_str());
    std::remove(faces_tmp_.c_str());
    throw;
  }
}

PlyWriter::~PlyWriter() {
  if (vf_) std::fclose(vf_);
  if (ff_) std::fclose(ff_);
  if (!finished_) std::remove(tmp_.c_str());
  std::remove(faces_tmp_.c_str());
}

std::string PlyWriter::header(std::size_t pad) const {
  std::string h = "ply\nformat binary_little_endian 1.0\ncomment rayline scene mesh\n";
  for (const auto& c : comments_) h += "comment " + c + "\n";
  h += "element vertex " + std::to_string(finished_ || pad ? vertices_ : 99999999999999999ull) + "\n";
  h += "property float x\nproperty float y\nproperty float z\n";
  h += "element face " + std::to_string(finished_ || pad ? triangles_ : 99999999999999999ull) + "\n";
  h += "property list uchar int vertex_indices\nproperty uchar material_index\n";
  if (pad) h += "comment " + std::string(pad - 9, '.') + "\n";
  return h + "end_header\n";
}

void PlyWriter::add(const MeshPiece& p) {
  if (finished_) throw std::logic_error("PlyWriter::add after finish");
  if (vertices_ + p.positions.size() > kMaxVertices)
    throw InputError(path_, "", "more than 2^31 vertices: split the mesh");
  const auto base = static_cast<std::uint32_t>(vertices_);
  for (const Float3& v : p.positions) {
    const auto n = vbuf_.size();
    vbuf_.resize(n + 12);
    put(put(put(vbuf_.data() + n, v.x), v.y), v.z);
    bounds_.extend(v);
    if (vbuf_.size() >= kBufferBytes) write_all(vf_, vbuf_, path_), vbuf_.clear();
  }
  const auto mat = static_cast<std::uint8_t>(std::min<std::uint16_t>(p.material, 255));
  const auto nv = p.positions.size();
  for (const Tri& t : p.triangles) {
    if (t[0] >= nv || t[1] >= nv || t[2] >= nv) throw std::logic_error("MeshPiece index out of range");
    const auto n = fbuf_.size();
    fbuf_.resize(n + 14);
    char* q = put<std::uint8_t>(fbuf_.data() + n, 3);
    for (auto i : t) q = put<std::int32_t>(q, static_cast<std::int32_t>(base + i));
    put<std::uint8_t>(q, mat);
    if (fbuf_.size() >= kBufferBytes) write_all(ff_, fbuf_, path_), fbuf_.clear();
  }
  vertices_ += p.positions.size();
  triangles_ += p.triangles.size();
}

void PlyWriter::finish() {
  if (finished_) return;
  write_all(vf_, vbuf_, path_), vbuf_.clear();
  write_all(ff_, fbuf_, path_), fbuf_.clear();
  if (std::fflush(ff_) != 0 || std::fflush(vf_) != 0) throw InputError(path_, "", "write failed");
  // Append the face section.
  std::rewind(ff_);
  std::vector<char> chunk(8u << 20);
  for (;;) {
    const std::size_t n = std::fread(chunk.data(), 1, chunk.size(), ff_);
    if (n == 0) break;
    if (std::fwrite(chunk.data(), 1, n, vf_) != n) throw InputError(path_, "", "write failed (disk full?)");
  }
  if (std::ferror(ff_)) throw InputError(path_, "", "cannot read back temporary face file");
  // Header into the reserved area, padded by a comment line to exactly reserved_ bytes.
  finished_ = true;
  std::string h = header(0);
  h = header(reserved_ - h.size());
  if (h.size() != reserved_) throw std::logic_error("PLY header padding mismatch");
  if (std::fseek(vf_, 0, SEEK_SET) != 0 || std::fwrite(h.data(), 1, h.size(), vf_) != h.size() ||
      std::fclose(vf_) != 0) {
    vf_ = nullptr;
    finished_ = false;
    throw InputError(path_, "", "write failed");
  }
  vf_ = nullptr;
  std::fclose(ff_);
  ff_ = nullptr;
  std::remove(faces_tmp_.c_str());
  std::error_code ec;
  std::filesystem::rename(tmp_, path_, ec);
  if (ec) {
    std::remove(tmp_.c_str());
    throw InputError(path_, "", "cannot rename temporary file into place: " + ec.message());
  }
}

}  // namespace rayline::scene
