// OpenEXR and PNG output (image_io.hpp). Every write goes to PATH.partial.<pid>@<host>, is
// fsync'ed, then renamed over PATH (rename is atomic within a folder); on any failure the
// partial file is removed and InputError(PATH, "output", …) is thrown.
#include "render/image/image_io.hpp"

#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFloatAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfIntAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <fcntl.h>
#include <png.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>

#include "common/error.hpp"
#include "common/unfinished_output.hpp"

namespace rayline::image {

namespace fs = std::filesystem;

namespace {

std::string partial_name(const std::string& path) { return unfinished::fresh_temp_name(path, "partial"); }

void remove_quietly(const std::string& file) {
  std::error_code ec;
  fs::remove(file, ec);
}

// Flushes the finished temporary file to disk before it replaces PATH, so a crash right
// after the rename cannot leave an empty file where a good one was.
bool sync_file(const std::string& file) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = ::fsync(fd) == 0;
  return ::close(fd) == 0 && ok;
}

void commit(const std::string& tmp, const std::string& path) {
  if (!sync_file(tmp)) {
    remove_quietly(tmp);
    throw InputError(path, "output", "cannot flush the finished file to disk");
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    remove_quietly(tmp);
    throw InputError(path, "output", "cannot rename the finished file into place: " + ec.message());
  }
}

void check_image_args(const std::string& path, int width, int height, const float* rgb) {
  if (width <= 0 || height <= 0)
    throw InputError(path, "output", "image size " + std::to_string(width) + "x" + std::to_string(height) +
                                         " is not positive");
  if (!rgb) throw InputError(path, "output", "no pixels");
}

// Names a default header already carries (channels, compression, dataWindow, ...).
const std::set<std::string>& standard_attributes() {
  static const std::set<std::string> names = [] {
    std::set<std::string> s;
    const Imf::Header h(1, 1);
    for (auto it = h.begin(); it != h.end(); ++it) s.insert(it.name());
    s.insert("channels");
    return s;
  }();
  return names;
}

}  // namespace

void write_exr(const std::string& path, int width, int height, const float* rgb, const Metadata& meta) {
  check_image_args(path, width, height, rgb);
  // Validate the keys before anything touches the disk.
  std::set<std::string> keys;
  auto add_key = [&](const std::string& k) {
    if (k.empty()) throw InputError(path, "output", "empty metadata key");
    if (standard_attributes().count(k))
      throw InputError(path, "output", "metadata key '" + k + "' is a standard OpenEXR attribute");
    if (!keys.insert(k).second) throw InputError(path, "output", "metadata key '" + k + "' given twice");
  };
  for (const auto& kv : meta.strings) add_key(kv.first);
  for (const auto& kv : meta.ints) add_key(kv.first);
  for (const auto& kv : meta.doubles) add_key(kv.first);

  const std::string tmp = partial_name(path);
  const unfinished::Guard unfinished_guard(tmp);  // removed if the run is interrupted
  try {
    Imf::Header h(width, height);  // ZIP compression by default: lossless
    // Float, not half: the image is the renderer's exact result (tests compare it bit for
    // bit, and half's 11-bit mantissa and 65504 ceiling would lose HDR radiance and noise
    // statistics); previews and viewers convert as they like.
    h.channels().insert("R", Imf::Channel(Imf::FLOAT));
    h.channels().insert("G", Imf::Channel(Imf::FLOAT));
    h.channels().insert("B", Imf::Channel(Imf::FLOAT));
    for (const auto& [k, v] : meta.strings) h.insert(k, Imf::StringAttribute(v));
    for (const auto& [k, v] : meta.ints) {
      if (v >= INT_MIN && v <= INT_MAX) h.insert(k, Imf::IntAttribute(static_cast<int>(v)));
      else h.insert(k, Imf::StringAttribute(std::to_string(v)));  // exact; no 64-bit int attribute
    }
    for (const auto& [k, v] : meta.doubles) h.insert(k, Imf::DoubleAttribute(v));
    Imf::FrameBuffer fb;
    const std::size_t xs = 3 * sizeof(float), ys = xs * std::size_t(width);
    char* base = reinterpret_cast<char*>(const_cast<float*>(rgb));  // OpenEXR only reads it
    fb.insert("R", Imf::Slice(Imf::FLOAT, base, xs, ys));
    fb.insert("G", Imf::Slice(Imf::FLOAT, base + sizeof(float), xs, ys));
    fb.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys));
    {
      Imf::OutputFile out(tmp.c_str(), h);  // the file is complete when `out` closes
      out.setFrameBuffer(fb);
      out.writePixels(height);
    }
  } catch (const std::exception& e) {
    remove_quietly(tmp);
    throw InputError(path, "output", std::string("cannot write OpenEXR: ") + e.what());
  }
  commit(tmp, path);
}

void write_png_preview(const std::string& path, int width, int height, const float* rgb, float exposure) {
  check_image_args(path, width, height, rgb);
  const std::string tmp = partial_name(path);
  const unfinished::Guard unfinished_guard(tmp);  // removed if the run is interrupted
  FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw InputError(path, "output", "cannot create the PNG preview");
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  std::vector<unsigned char> row(std::size_t(width) * 3);
  volatile bool ok = png && info;                 // volatile: read after longjmp
  if (ok && setjmp(png_jmpbuf(png))) ok = false;  // libpng reports errors by longjmp
  else if (ok) {
    png_init_io(png, f);
    png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);  // the pixels are sRGB-encoded
    png_write_info(png, info);
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width * 3; ++x) {
        float v = rgb[std::size_t(y) * std::size_t(width) * 3 + std::size_t(x)] * exposure;
        v = std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, 1.0f);
        // sRGB transfer curve (IEC 61966-2-1).
        v = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1 / 2.4f) - 0.055f;
        row[std::size_t(x)] = static_cast<unsigned char>(std::lround(v * 255));
      }
      png_write_row(png, row.data());
    }
    png_write_end(png, nullptr);
  }
  png_destroy_write_struct(png ? &png : nullptr, info ? &info : nullptr);
  const bool closed = std::fclose(f) == 0;
  if (!ok || !closed) {
    remove_quietly(tmp);
    throw InputError(path, "output", "cannot write the PNG preview");
  }
  commit(tmp, path);
}

ExrImage read_exr(const std::string& path) {
  ExrImage im;
  try {
    Imf::InputFile in(path.c_str());
    const Imath::Box2i dw = in.header().dataWindow();
    im.width = dw.max.x - dw.min.x + 1;
    im.height = dw.max.y - dw.min.y + 1;
    im.rgb.assign(std::size_t(im.width) * std::size_t(im.height) * 3, 0.0f);
    Imf::FrameBuffer fb;
    const std::size_t xs = 3 * sizeof(float), ys = xs * std::size_t(im.width);
    // OpenEXR addresses pixel (x, y) at base + x·xs + y·ys: shift base by the window origin.
    char* base = reinterpret_cast<char*>(im.rgb.data()) -
                 (std::ptrdiff_t(dw.min.x) * std::ptrdiff_t(xs) + std::ptrdiff_t(dw.min.y) * std::ptrdiff_t(ys));
    fb.insert("R", Imf::Slice(Imf::FLOAT, base, xs, ys));
    fb.insert("G", Imf::Slice(Imf::FLOAT, base + sizeof(float), xs, ys));
    fb.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys));
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    for (auto it = in.header().begin(); it != in.header().end(); ++it) {
      if (standard_attributes().count(it.name())) continue;
      const Imf::Attribute& a = it.attribute();
      if (auto* s = dynamic_cast<const Imf::StringAttribute*>(&a)) im.meta.strings[it.name()] = s->value();
      else if (auto* i = dynamic_cast<const Imf::IntAttribute*>(&a)) im.meta.ints[it.name()] = i->value();
      else if (auto* d = dynamic_cast<const Imf::DoubleAttribute*>(&a)) im.meta.doubles[it.name()] = d->value();
      else if (auto* fl = dynamic_cast<const Imf::FloatAttribute*>(&a)) im.meta.doubles[it.name()] = fl->value();
    }
  } catch (const std::exception& e) {
    throw InputError(path, "image", std::string("cannot read OpenEXR: ") + e.what());
  }
  return im;
}

}  // namespace rayline::image
