#include "render/scene/assets.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <unordered_map>

#include "render/scene/mesh_import.hpp"

namespace rayline::scene {
namespace fs = std::filesystem;

std::string assets_dir() {
  if (const char* e = std::getenv("RAYLINE_ASSETS"); e && *e) return e;
  // This file is render/scene/assets.cpp; the repository's assets/ is two levels up.
  return (fs::path(__FILE__).parent_path().parent_path().parent_path() / "assets").string();
}

namespace {

struct Key {
  std::uint32_t x, y, z;
  bool operator==(const Key&) const = default;
};
struct KeyHash {
  std::size_t operator()(const Key& k) const {
    std::uint64_t h = k.x * 0x9E3779B97F4A7C15ull ^ (std::uint64_t(k.y) * 0xC2B2AE3D27D4EB4Full + k.z);
    return std::size_t(h ^ (h >> 29));
  }
};
Key key_of(Float3 p) {
  Key k;
  std::memcpy(&k.x, &p.x, 4), std::memcpy(&k.y, &p.y, 4), std::memcpy(&k.z, &p.z, 4);
  return k;
}

std::shared_ptr<const AssetMesh> load_uncached(const std::string& path) {
  auto m = std::make_shared<AssetMesh>();
  m->name = fs::path(path).filename().string();
  std::unordered_map<Key, std::uint32_t, KeyHash> ids;
  auto id = [&](Float3 p) {
    if (p.x == 0) p.x = 0;  // fold -0
    if (p.y == 0) p.y = 0;
    if (p.z == 0) p.z = 0;
    auto [it, fresh] = ids.try_emplace(key_of(p), std::uint32_t(m->positions.size()));
    if (fresh) m->positions.push_back(p);
    return it->second;
  };
  stream_mesh_file(path, {}, [&](std::span<const Triangle> b) {
    for (const Triangle& t : b) {
      const Tri tri{id(t.v0), id(t.v1), id(t.v2)};
      if (tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2]) m->triangles.push_back(tri);
    }
  });
  Bounds b;
  for (Float3 p : m->positions) b.extend(p);
  const Float3 e = b.extent();
  const float s = 1.0f / std::max({e.x, e.y, e.z, 1e-20f});
  const Float3 o{b.center().x, b.lo.y, b.center().z};
  for (Float3& p : m->positions) p = (p - o) * s;
  m->normals.assign(m->positions.size(), Float3{});
  for (const Tri& t : m->triangles) {
    const Float3 n = cross(m->positions[t[1]] - m->positions[t[0]], m->positions[t[2]] - m->positions[t[0]]);
    for (auto i : t) m->normals[i] = m->normals[i] + n;
  }
  for (Float3& n : m->normals) {
    const float l = length(n);
    n = l > 0 ? n * (1.0f / l) : Float3{0, 1, 0};
  }
  return m;
}

}  // namespace

std::shared_ptr<const AssetMesh> load_asset_mesh(const std::string& path) {
  static std::mutex mu;
  static std::map<std::string, std::shared_ptr<const AssetMesh>> cache;
  std::lock_guard<std::mutex> lock(mu);
  std::error_code ec;
  const std::string key = fs::absolute(path, ec).lexically_normal().string() + "|" +
                          std::to_string(fs::file_size(path, ec));
  if (auto it = cache.find(key); it != cache.end()) return it->second;
  auto m = load_uncached(path);
  cache[key] = m;
  return m;
}

std::vector<std::string> scan_asset_files() {
  std::vector<std::string> files;
  for (const char* f : {"bunny.obj", "dragon.ply"}) {
    const fs::path p = fs::path(assets_dir()) / f;
    std::error_code ec;
    if (fs::is_regular_file(p, ec)) files.push_back(p.string());
  }
  return files;
}

std::vector<std::string> cad_asset_files() {
  std::vector<std::string> files;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(fs::path(assets_dir()) / "occt", ec)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (ext == ".stl" && e.is_regular_file(ec)) files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<std::shared_ptr<const AssetMesh>> scan_assets() {
  std::vector<std::shared_ptr<const AssetMesh>> r;
  for (const std::string& f : scan_asset_files()) r.push_back(load_asset_mesh(f));
  return r;
}

std::vector<std::shared_ptr<const AssetMesh>> cad_assets() {
  std::vector<std::shared_ptr<const AssetMesh>> r;
  for (const std::string& f : cad_asset_files()) {
    try {
      auto m = load_asset_mesh(f);
      if (!m->triangles.empty()) r.push_back(m);
    } catch (const std::exception&) {
      // skip unreadable parts: the generator still has its procedural ones
    }
  }
  return r;
}

std::string AssetReport::summary() const {
  if (files.empty()) return "procedural only (no assets found in " + assets_dir() + ")";
  std::string s = std::to_string(asset_items) + " from assets (";
  for (std::size_t i = 0; i < files.size(); ++i) s += (i ? ", " : "") + files[i];
  s += ")";
  if (procedural_items) s += ", " + std::to_string(procedural_items) + " procedural";
  return s;
}

AssetReport& last_asset_report() {
  thread_local AssetReport r;
  return r;
}

}  // namespace rayline::scene
