// Real meshes for the generators (scripts/fetch_assets.sh puts them in assets/):
// scans (bunny.obj, dragon.ply) for museum-like statues, CAD parts (occt/*.stl) for
// boeing-like. The folder is $RAYLINE_ASSETS, else the repository's assets/ folder
// (resolved at compile time). Missing assets are not an error: generators fall back to
// procedural geometry and say so in their report / companion scene description.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "render/scene/mesh_sink.hpp"

namespace rayline::scene {

std::string assets_dir();  // read on every call (tests point it elsewhere)

// An indexed mesh, welded on exact positions and normalised: centred in x and z, base at
// y = 0, largest extent 1. Normals are area-weighted vertex normals.
struct AssetMesh {
  std::string name;  // file name, e.g. "bunny.obj"
  std::vector<Float3> positions, normals;
  std::vector<Tri> triangles;
};

// Loads (once per process and path; later calls share the copy) the mesh at `path`.
std::shared_ptr<const AssetMesh> load_asset_mesh(const std::string& path);

// The asset files present: the scans (bunny.obj, dragon.ply, in that order), then the CAD
// parts occt/*.stl sorted by name. (Generators read them; `generate` never writes over one.)
std::vector<std::string> scan_asset_files();
std::vector<std::string> cad_asset_files();

// Scans present in assets_dir(), in fixed order (bunny.obj, dragon.ply).
std::vector<std::shared_ptr<const AssetMesh>> scan_assets();
// CAD parts assets_dir()/occt/*.stl, sorted by file name; unreadable files are skipped.
std::vector<std::shared_ptr<const AssetMesh>> cad_assets();

// What the last generator run on this thread used (museum: statues; boeing: parts).
struct AssetReport {
  std::string generator;
  std::uint64_t asset_items = 0;       // statues from scans / parts from STL files
  std::uint64_t procedural_items = 0;  // procedural statues (museum) — parts are not counted
  std::vector<std::string> files;      // asset files available to it
  std::string summary() const;
};
AssetReport& last_asset_report();

}  // namespace rayline::scene
