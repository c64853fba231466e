#include "render/image/image_io.hpp"

#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfIntAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <png.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "sched/error.hpp"

namespace rayline::image {

namespace fs = std::filesystem;

namespace {

std::string partial_name(const std::string& path) {
  return path + ".partial." + std::to_string(::getpid());
}

void commit(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw InputError(path, "output", "cannot rename the finished file into place");
  }
}

}  // namespace

void write_exr(const std::string& path, int width, int height, const float* rgb, const Metadata& meta) {
  const std::string tmp = partial_name(path);
  try {
    Imf::Header h(width, height);
    // Float, not half: the image is the renderer's exact result (tests compare it bit for
    // bit); previews and viewers convert as they like.
    h.channels().insert("R", Imf::Channel(Imf::FLOAT));
    h.channels().insert("G", Imf::Channel(Imf::FLOAT));
    h.channels().insert("B", Imf::Channel(Imf::FLOAT));
    for (const auto& [k, v] : meta.strings) h.insert(k, Imf::StringAttribute(v));
    for (const auto& [k, v] : meta.ints) h.insert(k, Imf::IntAttribute(static_cast<int>(v)));
    for (const auto& [k, v] : meta.doubles) h.insert(k, Imf::DoubleAttribute(v));
    Imf::FrameBuffer fb;
    const std::size_t xs = 3 * sizeof(float), ys = xs * std::size_t(width);
    char* base = reinterpret_cast<char*>(const_cast<float*>(rgb));
    fb.insert("R", Imf::Slice(Imf::FLOAT, base, xs, ys));
    fb.insert("G", Imf::Slice(Imf::FLOAT, base + sizeof(float), xs, ys));
    fb.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys));
    {
      Imf::OutputFile out(tmp.c_str(), h);
      out.setFrameBuffer(fb);
      out.writePixels(height);
    }
  } catch (const std::exception& e) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw InputError(path, "output", std::string("cannot write OpenEXR: ") + e.what());
  }
  commit(tmp, path);
}

void write_png_preview(const std::string& path, int width, int height, const float* rgb, float exposure) {
  const std::string tmp = partial_name(path);
  FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw InputError(path, "output", "cannot create the PNG preview");
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  std::vector<unsigned char> row(std::size_t(width) * 3);
  volatile bool ok = png && info;  // volatile: read after longjmp
  if (ok && setjmp(png_jmpbuf(png))) ok = false;  // libpng reports errors by longjmp
  else if (ok) {
    png_init_io(png, f);
    png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width * 3; ++x) {
        float v = std::clamp(rgb[std::size_t(y) * std::size_t(width) * 3 + std::size_t(x)] * exposure, 0.0f, 1.0f);
        if (!(v == v)) v = 0;
        v = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1 / 2.4f) - 0.055f;  // sRGB
        row[std::size_t(x)] = static_cast<unsigned char>(std::lround(v * 255));
      }
      png_write_row(png, row.data());
    }
    png_write_end(png, nullptr);
  }
  png_destroy_write_struct(png ? &png : nullptr, info ? &info : nullptr);
  const bool closed = std::fclose(f) == 0;
  if (!ok || !closed) {
    std::error_code ec;
    fs::remove(tmp, ec);
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
    char* base = reinterpret_cast<char*>(im.rgb.data()) - (std::ptrdiff_t(dw.min.x) * std::ptrdiff_t(xs) +
                                                           std::ptrdiff_t(dw.min.y) * std::ptrdiff_t(ys));
    fb.insert("R", Imf::Slice(Imf::FLOAT, base, xs, ys));
    fb.insert("G", Imf::Slice(Imf::FLOAT, base + sizeof(float), xs, ys));
    fb.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys));
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    for (auto it = in.header().begin(); it != in.header().end(); ++it) {
      if (auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute())) im.meta.strings[it.name()] = s->value();
      else if (auto* i = dynamic_cast<const Imf::IntAttribute*>(&it.attribute())) im.meta.ints[it.name()] = i->value();
      else if (auto* d = dynamic_cast<const Imf::DoubleAttribute*>(&it.attribute())) im.meta.doubles[it.name()] = d->value();
    }
  } catch (const std::exception& e) {
    throw InputError(path, "image", std::string("cannot read OpenEXR: ") + e.what());
  }
  return im;
}

}  // namespace rayline::image
