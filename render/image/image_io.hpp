// Image outputs users expect (docs/architecture.md): OpenEXR (linear RGB, 32-bit float, with the
// run's metadata as header attributes) and an 8-bit sRGB PNG preview. Both are written to
// `path + ".partial.<pid>@<host>"` in the target folder, flushed to disk, then renamed over
// `path`, so a failed write never leaves a half-written file in place of a good one (and
// leaves no partial file behind). OpenEXR and libpng stay in the .cpp.
#pragma once
#include <map>
#include <string>
#include <vector>

namespace rayline::image {

// Header attributes. Keys must be non-empty, unique across the three maps, and must not
// name a standard OpenEXR attribute ("channels", "compression", "dataWindow", ...).
//  * strings → StringAttribute;
//  * ints    → IntAttribute when the value fits 32 bits (OpenEXR has no 64-bit integer
//              attribute); otherwise a StringAttribute holding the exact decimal value
//              (so read_exr returns it among `strings`);
//  * doubles → DoubleAttribute.
struct Metadata {
  std::map<std::string, std::string> strings;
  std::map<std::string, long long> ints;
  std::map<std::string, double> doubles;
  friend bool operator==(const Metadata&, const Metadata&) = default;
};

// `rgb`: width·height·3 floats, top row first, written as 32-bit float channels R, G, B
// (ZIP compression: lossless, so the file holds the renderer's exact values).
// Throws InputError(path, "output", …) on bad arguments or any write failure.
void write_exr(const std::string& path, int width, int height, const float* rgb, const Metadata& meta);

// 8-bit sRGB preview: v' = clamp(exposure·v, 0, 1) (NaN → 0), then the sRGB transfer curve
// (IEC 61966-2-1), rounded to the nearest of 0..255. Throws InputError(path, "output", …).
void write_png_preview(const std::string& path, int width, int height, const float* rgb, float exposure = 1.0f);

struct ExrImage {
  int width = 0, height = 0;
  std::vector<float> rgb;  // width·height·3, top row first; missing channels read as 0
  Metadata meta;           // string, int, float and double attributes other than the standard ones
};
// Reads an RGB(A) OpenEXR file (tests, tools). Throws InputError(path, "image", …).
ExrImage read_exr(const std::string& path);

}  // namespace rayline::image
