// Import throughput: streams each mesh file given on the command line through
// Rayline's native readers (or assimp with --assimp), counting triangles, and prints
// M triangles/s, MB/s of file and the process's peak RSS. Run one file per process for a
// clean peak: `build/bench/bench_import FILE [--assimp]`. Numbers in scenes/README.md.
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "render/scene/mesh_import.hpp"

using namespace rayline::scene;

int main(int argc, char** argv) {
  bool assimp = false;
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--assimp") assimp = true;
    else if (a == "--help" || a == "-h") {
      std::printf("usage: bench_import FILE... [--assimp]\n");
      return 0;
    } else files.push_back(a);
  }
  if (files.empty()) {
    std::fprintf(stderr, "usage: bench_import FILE... [--assimp]\n");
    return 2;
  }
  for (const std::string& f : files) {
    std::uint64_t n = 0;
    const auto t0 = std::chrono::steady_clock::now();
    try {
      stream_mesh_file(f, {}, [&](std::span<const Triangle> b) { n += b.size(); },
                       assimp ? ImportPath::assimp : ImportPath::automatic);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "bench_import: %s\n", e.what());
      return 2;
    }
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    struct rusage u {};
    ::getrusage(RUSAGE_SELF, &u);
    std::printf("%s (%s): %llu triangles in %.2f s = %.2f M triangles/s, %.1f MB/s; peak RSS %.0f MiB\n", f.c_str(),
                assimp ? "assimp" : "native", static_cast<unsigned long long>(n), s, double(n) / s / 1e6,
                double(std::filesystem::file_size(f)) / s / 1e6, double(u.ru_maxrss) / 1024.0);
  }
  return 0;
}
