// Image outputs users expect (DESIGN.md): OpenEXR (linear RGB, 32-bit float, with the
// run's metadata as header attributes) and an 8-bit sRGB PNG preview. Both are written to
// a temporary name in the target folder and renamed when complete, so a failed write never
// leaves a half-written file in place of a good one. OpenEXR and libpng stay in the .cpp.
#pragma once
#include <map>
#include <string>
#include <vector>

namespace rayline::image {

struct Metadata {
  std::map<std::string, std::string> strings;
  std::map<std::string, long long> ints;
  std::map<std::string, double> doubles;
};

// `rgb`: width·height·3 floats, top row first. Throws InputError(path, "output", …).
void write_exr(const std::string& path, int width, int height, const float* rgb, const Metadata& meta);
// Tone map: clamp(exposure·v) then the sRGB transfer curve.
void write_png_preview(const std::string& path, int width, int height, const float* rgb, float exposure = 1.0f);

struct ExrImage {
  int width = 0, height = 0;
  std::vector<float> rgb;
  Metadata meta;
};
// Reads an RGB(A) OpenEXR file (tests, tools). Throws InputError(path, …).
ExrImage read_exr(const std::string& path);

}  // namespace rayline::image
