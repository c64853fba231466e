// Image output (render/image): OpenEXR round trip (pixels bit-identical, metadata kept),
// the PNG preview read back with libpng (size, format, tone-mapped values), and the
// atomic-write rule: an unwritable path or a write that fails half-way throws
// InputError(path, "output", …), leaves no PATH.partial.* file, and leaves an existing
// good file byte-for-byte untouched. Mid-write failures are made real with RLIMIT_FSIZE
// (the kernel refuses to grow a file past the limit: EFBIG).
#include <gtest/gtest.h>
#include <png.h>
#include <sys/resource.h>
#include <unistd.h>

#include <csignal>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "render/image/image_io.hpp"
#include "common/error.hpp"

namespace fs = std::filesystem;
using namespace rayline::image;

namespace {

struct TempDir {
  fs::path dir;
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir = fs::temp_directory_path() / ("rayline-image-" + std::string(info->name()) + "-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
  std::string operator/(const std::string& name) const { return (dir / name).string(); }
  // Names of leftover temporaries (anything with ".partial." in its name).
  std::vector<std::string> partials() const {
    std::vector<std::string> out;
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (e.path().filename().string().find(".partial.") != std::string::npos) out.push_back(e.path().string());
    return out;
  }
};

std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// Deterministic, incompressible-ish float noise (xorshift), so a large image is large on disk.
std::vector<float> noise_image(int w, int h) {
  std::vector<float> v(std::size_t(w) * std::size_t(h) * 3);
  std::uint32_t s = 2463534242u;
  for (float& x : v) {
    s ^= s << 13, s ^= s >> 17, s ^= s << 5;
    x = float(s) * 0x1p-32f * 4.0f;
  }
  return v;
}

// Limits the size of any file this process grows (RLIMIT_FSIZE) for the guard's lifetime;
// SIGXFSZ is ignored so the write fails with EFBIG instead of killing the process.
struct FileSizeLimit {
  rlimit old{};
  void (*old_handler)(int) = nullptr;
  explicit FileSizeLimit(rlim_t bytes) {
    old_handler = std::signal(SIGXFSZ, SIG_IGN);
    getrlimit(RLIMIT_FSIZE, &old);
    rlimit lim = old;
    lim.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &lim);
  }
  ~FileSizeLimit() {
    setrlimit(RLIMIT_FSIZE, &old);
    std::signal(SIGXFSZ, old_handler);
  }
};

void expect_output_error(const std::function<void()>& write, const std::string& path) {
  try {
    write();
    ADD_FAILURE() << "expected InputError for " << path;
  } catch (const rayline::InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.field(), "output");
  }
}

}  // namespace

TEST(image, ExrRoundTripIsBitIdenticalWithMetadata) {
  TempDir tmp;
  const int w = 7, h = 5;
  std::vector<float> rgb = noise_image(w, h);
  // Values half floats would lose or mangle: tiny, huge, negative zero, denormal, inf, NaN.
  rgb[0] = 1e-30f, rgb[1] = 3.0e38f, rgb[2] = -0.0f, rgb[3] = std::numeric_limits<float>::denorm_min();
  rgb[4] = std::numeric_limits<float>::infinity(), rgb[5] = std::numeric_limits<float>::quiet_NaN();
  rgb[6] = 0.1f, rgb[7] = -2.5f, rgb[8] = 65520.0f;
  Metadata meta;
  meta.strings["rayline.scheduler"] = "gmb k=2s";
  meta.strings["rayline.scene"] = "scenes/cornell.json";
  meta.ints["rayline.spp"] = 64;
  meta.ints["rayline.negative"] = -7;
  meta.ints["rayline.seed"] = 0x123456789abcLL;  // beyond 32 bits: stored exactly as a string
  meta.doubles["rayline.seconds"] = 12.345678901234567;
  const std::string path = tmp / "img.exr";
  write_exr(path, w, h, rgb.data(), meta);
  EXPECT_TRUE(tmp.partials().empty());

  const ExrImage im = read_exr(path);
  ASSERT_EQ(im.width, w);
  ASSERT_EQ(im.height, h);
  ASSERT_EQ(im.rgb.size(), rgb.size());
  EXPECT_EQ(std::memcmp(im.rgb.data(), rgb.data(), rgb.size() * sizeof(float)), 0) << "pixels bit-identical";
  Metadata expect = meta;
  expect.ints.erase("rayline.seed");
  expect.strings["rayline.seed"] = std::to_string(0x123456789abcLL);
  EXPECT_EQ(im.meta.strings, expect.strings);
  EXPECT_EQ(im.meta.ints, expect.ints);
  EXPECT_EQ(im.meta.doubles, expect.doubles);  // doubles exact, not rounded to float

  // Overwriting an existing file replaces it completely.
  const std::vector<float> other(std::size_t(2) * 3 * 3, 0.5f);
  write_exr(path, 2, 3, other.data(), {});
  const ExrImage again = read_exr(path);
  EXPECT_EQ(again.width, 2);
  EXPECT_EQ(again.rgb, other);
  EXPECT_TRUE(again.meta.strings.empty() && again.meta.ints.empty() && again.meta.doubles.empty());
}

TEST(image, PngPreviewIsValidSrgb) {
  TempDir tmp;
  const int w = 4, h = 2;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  // Row 0: black, white, 0.5, 0.25 (×2 exposure below); row 1: negative, > 1, NaN, tiny.
  const std::vector<float> rgb = {0, 0, 0,    1, 1, 1,   0.5f, 0.5f, 0.5f,  0.25f, 0.25f, 0.25f,
                                  -1, -1, -1, 7, 7, 7,   nan, nan, nan,     0.001f, 0.5f, 1.0f};
  const std::string path = tmp / "img.png";
  write_png_preview(path, w, h, rgb.data(), 1.0f);
  EXPECT_TRUE(tmp.partials().empty());

  png_image img;
  std::memset(&img, 0, sizeof img);
  img.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&img, path.c_str())) << img.message;
  EXPECT_EQ(img.width, png_uint_32(w));
  EXPECT_EQ(img.height, png_uint_32(h));
  EXPECT_EQ(img.format & PNG_FORMAT_FLAG_COLOR, png_uint_32(PNG_FORMAT_FLAG_COLOR));
  EXPECT_EQ(img.format & PNG_FORMAT_FLAG_ALPHA, 0u);
  img.format = PNG_FORMAT_RGB;
  std::vector<unsigned char> px(PNG_IMAGE_SIZE(img));
  ASSERT_TRUE(png_image_finish_read(&img, nullptr, px.data(), 0, nullptr)) << img.message;
  // sRGB encode: 12.92·v below 0.0031308, else 1.055·v^(1/2.4) − 0.055; ×255, rounded.
  auto srgb8 = [](double v) {
    v = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055;
    return int(std::lround(v * 255));
  };
  const int expect[] = {0, 0, 0,   255, 255, 255, srgb8(0.5), srgb8(0.5), srgb8(0.5), srgb8(0.25), srgb8(0.25), srgb8(0.25),
                        0, 0, 0,   255, 255, 255, 0, 0, 0,                            srgb8(0.001), srgb8(0.5), 255};
  ASSERT_EQ(px.size(), std::size(expect));
  for (std::size_t i = 0; i < px.size(); ++i) EXPECT_NEAR(int(px[i]), expect[i], 1) << "byte " << i;
  EXPECT_EQ(srgb8(0.5), 188);

  // Exposure scales before the clamp: 0.25 × 2 encodes like 0.5.
  write_png_preview(path, w, h, rgb.data(), 2.0f);
  png_image img2;
  std::memset(&img2, 0, sizeof img2);
  img2.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&img2, path.c_str())) << img2.message;
  img2.format = PNG_FORMAT_RGB;
  std::vector<unsigned char> px2(PNG_IMAGE_SIZE(img2));
  ASSERT_TRUE(png_image_finish_read(&img2, nullptr, px2.data(), 0, nullptr)) << img2.message;
  EXPECT_NEAR(int(px2[9]), 188, 1);
  EXPECT_EQ(int(px2[6]), 255);
}

TEST(image, UnwritablePathThrowsAndLeavesNothing) {
  TempDir tmp;
  const std::vector<float> rgb(4 * 4 * 3, 0.5f);
  const std::string missing = tmp / "no-such-folder/img.exr";
  expect_output_error([&] { write_exr(missing, 4, 4, rgb.data(), {}); }, missing);
  const std::string missing_png = tmp / "no-such-folder/img.png";
  expect_output_error([&] { write_png_preview(missing_png, 4, 4, rgb.data()); }, missing_png);
  // The target is a folder: the temporary is written, the rename fails, the temporary goes.
  fs::create_directories(tmp / "taken.exr");
  fs::create_directories(tmp / "taken.png");
  expect_output_error([&] { write_exr(tmp / "taken.exr", 4, 4, rgb.data(), {}); }, tmp / "taken.exr");
  expect_output_error([&] { write_png_preview(tmp / "taken.png", 4, 4, rgb.data()); }, tmp / "taken.png");
  EXPECT_TRUE(fs::is_directory(tmp / "taken.exr"));
  // Bad arguments are refused before anything is written.
  expect_output_error([&] { write_exr(tmp / "zero.exr", 0, 4, rgb.data(), {}); }, tmp / "zero.exr");
  Metadata clash;
  clash.strings["compression"] = "none";
  expect_output_error([&] { write_exr(tmp / "clash.exr", 4, 4, rgb.data(), clash); }, tmp / "clash.exr");
  Metadata twice;
  twice.strings["k"] = "a";
  twice.ints["k"] = 1;
  expect_output_error([&] { write_exr(tmp / "twice.exr", 4, 4, rgb.data(), twice); }, tmp / "twice.exr");
  EXPECT_TRUE(tmp.partials().empty()) << tmp.partials().front();
  EXPECT_FALSE(fs::exists(tmp / "zero.exr"));
  EXPECT_FALSE(fs::exists(tmp / "clash.exr"));
  EXPECT_FALSE(fs::exists(tmp / "twice.exr"));
  // Reading a missing file is an error naming it.
  EXPECT_THROW(read_exr(tmp / "absent.exr"), rayline::InputError);
}

TEST(image, FailedWriteLeavesGoodFileUntouched) {
  TempDir tmp;
  const std::vector<float> small(8 * 8 * 3, 0.25f);
  const std::string exr = tmp / "good.exr", png = tmp / "good.png";
  write_exr(exr, 8, 8, small.data(), {});
  write_png_preview(png, 8, 8, small.data());
  const std::string good_exr = slurp(exr), good_png = slurp(png);
  ASSERT_FALSE(good_exr.empty());
  ASSERT_FALSE(good_png.empty());

  // A large noisy image cannot be written under a 4 KiB file-size limit: the writes of the
  // temporary fail half-way (EFBIG).
  const std::vector<float> big = noise_image(256, 256);
  {
    FileSizeLimit limit(4096);
    expect_output_error([&] { write_exr(exr, 256, 256, big.data(), {}); }, exr);
    expect_output_error([&] { write_png_preview(png, 256, 256, big.data()); }, png);
  }
  EXPECT_EQ(slurp(exr), good_exr) << "the good EXR must be untouched";
  EXPECT_EQ(slurp(png), good_png) << "the good PNG must be untouched";
  EXPECT_TRUE(tmp.partials().empty());
  // And the limit was the only problem: the same writes succeed without it.
  write_exr(exr, 256, 256, big.data(), {});
  EXPECT_EQ(read_exr(exr).rgb, big);
}
