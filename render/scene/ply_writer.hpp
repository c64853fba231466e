// Streaming binary little-endian PLY writer: the on-disk mesh format of generated scenes.
// Memory stays bounded whatever the size: vertices go straight to PATH.tmp.<pid>@<host>, faces
// to a second temporary file appended at finish(); the header (written last, into a
// fixed-size reserved area) carries the counts; the file appears under PATH only
// complete (rename). Layout, for readers that stream it (render/ partitioner):
//   element vertex N: float x, y, z
//   element face M:   list uchar int vertex_indices (always 3), uchar material_index
#pragma once
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "render/scene/mesh_sink.hpp"
#include "common/unfinished_output.hpp"

namespace rayline::scene {

class PlyWriter final : public MeshSink {
 public:
  // Opens the temporaries; throws InputError(path) when the folder is not writable.
  explicit PlyWriter(std::string path, std::vector<std::string> comments = {});
  ~PlyWriter() override;  // without finish(): removes the temporaries, leaves PATH alone
  PlyWriter(const PlyWriter&) = delete;
  PlyWriter& operator=(const PlyWriter&) = delete;

  void add(const MeshPiece& piece) override;
  void finish();

  std::uint64_t vertex_count() const { return vertices_; }
  std::uint64_t triangle_count() const { return triangles_; }
  const Bounds& bounds() const { return bounds_; }

 private:
  std::string header(std::size_t pad) const;

  std::string path_, tmp_, faces_tmp_;
  // Registered for the writer's lifetime: removed if the run is interrupted.
  unfinished::Guard tmp_guard_{tmp_}, faces_guard_{faces_tmp_};
  std::vector<std::string> comments_;
  std::FILE* vf_ = nullptr;
  std::FILE* ff_ = nullptr;
  std::vector<char> vbuf_, fbuf_;
  std::size_t reserved_ = 0;
  std::uint64_t vertices_ = 0, triangles_ = 0;
  Bounds bounds_;
  bool finished_ = false;
};

}  // namespace rayline::scene
