#include "apps/cli_common.hpp"

#include <fcntl.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <unistd.h>

#include "apps/run/output_set.hpp"
#include "common/error.hpp"
#include "common/output_folder.hpp"
#include "common/unfinished_output.hpp"
#include "common/units.hpp"

namespace rayline::cli {

namespace {
const char* const kDurationUnits = "ns, us, ms, s, min, h";
const char* const kSizeUnits = "B, kB, MB, GB, TB, KiB, MiB, GiB, TiB";

// The whole text is a number (no unit after it): "2", "-1", "1e3".
bool bare_number(const std::string& text) {
  if (text.empty()) return false;
  char* end = nullptr;
  std::strtod(text.c_str(), &end);
  return end != text.c_str() && *end == '\0';
}

// Three significant digits of `v` (1 <= |v| < 1000): "4.27", "42.7", "427"; larger
// values (past the last prefix) whole: "1234".
std::string three_digits(double v) {
  const double a = std::fabs(v);
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", a < 9.995 ? 2 : a < 99.95 ? 1 : 0, v);
  return buf;
}

// `v` divided by the largest of `steps` (ascending) that it reaches (after rounding to
// three digits), and that step's prefix; values under the first step keep no prefix.
struct Scaled {
  double value;
  const char* prefix;
};
template <std::size_t N>
Scaled scale(double v, const double (&steps)[N], const char* const (&prefixes)[N]) {
  Scaled s{v, ""};
  for (std::size_t i = 0; i < N; ++i)
    if (std::fabs(v) >= steps[i] * 0.9995) s = {v / steps[i], prefixes[i]};
  return s;
}

// Outside the finite numbers, or under the smallest unit: printf's %.3g.
std::string general(double v, const std::string& unit) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.3g %s", v, unit.c_str());
  return buf;
}
}  // namespace

double duration_flag(const std::string& flag, const std::string& text) {
  if (bare_number(text))
    throw InputError(flag, "", "'" + text + "' has no unit; a duration takes one, e.g. 2s or 500ms (units: " +
                                   kDurationUnits + ")");
  try {
    return units::parse_duration(text);
  } catch (const std::invalid_argument& e) {
    throw InputError(flag, "", std::string(e.what()) + " (units: " + kDurationUnits + ")");
  }
}

std::uint64_t size_flag(const std::string& flag, const std::string& text) {
  if (bare_number(text))
    throw InputError(flag, "", "'" + text + "' has no unit; a size takes one, e.g. 512MiB or 64GiB (units: " +
                                   kSizeUnits + ")");
  double bytes = 0;
  try {
    bytes = units::parse_bytes(text);
  } catch (const std::invalid_argument& e) {
    throw InputError(flag, "", std::string(e.what()) + " (units: " + kSizeUnits + ")");
  }
  const double whole = std::round(bytes);
  if (whole < 1) throw InputError(flag, "", "'" + text + "' is less than 1B");
  return static_cast<std::uint64_t>(whole);
}

std::string format_duration(double seconds) {
  static const double steps[] = {1e-9, 1e-6, 1e-3, 1};
  static const char* const units[] = {"ns", "us", "ms", "s"};
  const Scaled s = scale(seconds, steps, units);
  if (!std::isfinite(seconds) || !*s.prefix) return general(seconds, "s");
  return three_digits(s.value) + " " + s.prefix;
}

std::string format_size(double bytes) {
  static const double steps[] = {1024.0, 1048576.0, 1073741824.0, 1099511627776.0};
  static const char* const prefixes[] = {"KiB", "MiB", "GiB", "TiB"};
  const Scaled s = scale(bytes, steps, prefixes);
  if (!std::isfinite(bytes)) return general(bytes, "B");
  if (!*s.prefix) return std::to_string(std::llround(bytes)) + " B";
  return three_digits(s.value) + " " + s.prefix;
}

std::string format_rate(double per_second, const std::string& what) {
  static const double steps[] = {1e3, 1e6, 1e9, 1e12};
  static const char* const prefixes[] = {"k ", "M ", "G ", "T "};
  const Scaled s = scale(per_second, steps, prefixes);
  if (!std::isfinite(per_second) || !*s.prefix) return general(per_second, what + "/s");
  return three_digits(s.value) + " " + s.prefix + what + "/s";
}

std::string format_bandwidth(double bytes_per_second) {
  static const double steps[] = {1e3, 1e6, 1e9, 1e12};
  static const char* const prefixes[] = {"kB/s", "MB/s", "GB/s", "TB/s"};
  const Scaled s = scale(bytes_per_second, steps, prefixes);
  if (!std::isfinite(bytes_per_second) || !*s.prefix) return general(bytes_per_second, "B/s");
  return three_digits(s.value) + " " + s.prefix;
}

int guarded(const std::function<int()>& body) {
  try {
    return body();
  } catch (const InputError& e) {
    std::cerr << "rayline: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "rayline: error: " << e.what() << "\n";
    return kExitFailure;
  }
}

void ensure_parent_dir(const std::string& path, const std::string& flag) {
  namespace fs = std::filesystem;
  if (path.empty()) throw InputError(path, flag, "missing output path");
  const fs::path parent = fs::absolute(fs::path(path)).parent_path();
  std::error_code ec;
  if (fs::is_directory(parent, ec)) return;
  fs::create_directories(parent, ec);
  if (ec || !fs::is_directory(parent)) throw InputError(path, flag, "cannot create folder " + parent.string() + ": " + ec.message());
}

void ensure_dir(const std::string& dir, const std::string& flag) {
  namespace fs = std::filesystem;
  if (dir.empty()) throw InputError(dir, flag, "missing output folder");
  std::error_code ec;
  if (fs::is_directory(dir, ec)) return;
  fs::create_directories(dir, ec);
  std::error_code ignored;
  if (ec || !fs::is_directory(dir, ignored))
    throw InputError(dir, flag, "cannot create the folder" + (ec ? ": " + ec.message() : std::string()));
}

void check_output_file(const std::string& path, const std::string& flag, const std::string& example) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!path.empty() && fs::is_directory(path, ec))
    throw InputError(path, flag, "is a folder; give a file name such as " + example);
  ensure_parent_dir(path, flag);
  const fs::path probe = fs::absolute(path).parent_path() / (".rayline-probe." + std::to_string(::getpid()));
  std::ofstream f(probe);
  if (!f) throw InputError(path, flag, "output folder is not writable");
  f.close();
  fs::remove(probe, ec);
}

namespace {
bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec;
  if (std::filesystem::exists(a, ec) && std::filesystem::exists(b, ec)) return std::filesystem::equivalent(a, b, ec);
  return normal_path(a) == normal_path(b);
}
}  // namespace

void check_distinct(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs) {
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    if (outputs[i].path.empty()) continue;
    for (std::size_t j = 0; j < i; ++j)
      if (!outputs[j].path.empty() && same_file(outputs[i].path, outputs[j].path))
        throw InputError(outputs[i].path, outputs[i].flag,
                         "is also the file of " + outputs[j].flag + "; give each output its own name");
    for (const NamedPath& in : inputs)
      if (!in.path.empty() && same_file(outputs[i].path, in.path))
        throw InputError(outputs[i].path, outputs[i].flag,
                         "is the input of " + in.flag + "; writing it would destroy that file");
  }
}

void check_not_inside(const std::string& folder, const std::string& folder_flag, const std::vector<NamedPath>& inputs) {
  for (const NamedPath& in : inputs)
    if (!in.path.empty() && folder_holds(folder, in.path))
      throw InputError(in.path, in.flag, "lies inside " + folder_flag + " " + folder +
                                             ", which the run replaces; move it out or choose another " + folder_flag);
}

void write_file_atomic(const std::string& path, const std::string& content) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw InputError(path, "", "is a folder; cannot write the file there");
  ensure_parent_dir(path, "");
  const fs::path target(path);
  const fs::path tmp = unfinished::fresh_temp_name(target.string(), "tmp");
  const unfinished::Guard unfinished_guard(tmp.string());  // removed if the run is interrupted
  const auto fail = [&](const std::string& why) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw OutputWriteError(path, why);
  };
  try {
    write_whole_file(tmp.string(), content);
  } catch (const std::runtime_error& e) {
    fail(e.what());
  }
  fs::rename(tmp, target, ec);
  if (ec) fail("cannot move it into place: " + ec.message());
}

}  // namespace rayline::cli
