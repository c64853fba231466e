// Strict unit parsing (see units.hpp). Grammar: NUMBER UNIT, no spaces inside, where
// NUMBER is a plain decimal (digits, optional fraction, optional exponent).
#include "common/units.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <stdexcept>
#include <string>

namespace rayline::units {

namespace {

// Bounds past which a quantity is a typo, not a device: products of sizes, times and
// inverse bandwidths then stay far from overflow (see parse_bytes / parse_bandwidth).
constexpr double kMaxBytes = 1152921504606846976.0;  // 1 EiB = 2^60 B
constexpr double kMaxSeconds = 1e9;                  // about 32 years

struct Split {
  double value;
  std::string_view unit;
};

Split split(std::string_view text, const char* what, const char* example) {
  auto fail = [&](const std::string& why) {
    throw std::invalid_argument("'" + std::string(text) + "' is not a valid " + what + " (" + why + "; expected e.g. " +
                                example + ")");
  };
  if (text.empty()) fail("empty");
  std::size_t i = 0;
  while (i < text.size() && (std::isdigit(static_cast<unsigned char>(text[i])) || text[i] == '.' || text[i] == '-' ||
                             text[i] == '+' ||
                             ((text[i] == 'e' || text[i] == 'E') && i + 1 < text.size() &&
                              (std::isdigit(static_cast<unsigned char>(text[i + 1])) || text[i + 1] == '-' || text[i + 1] == '+'))))
    ++i;
  if (i == 0) fail("no number");
  double v = 0;
  const auto [p, ec] = std::from_chars(text.data(), text.data() + i, v);
  if (ec != std::errc() || p != text.data() + i) fail("malformed number");
  if (!std::isfinite(v)) fail("not finite");
  if (v < 0) fail("negative");
  const std::string_view unit = text.substr(i);
  if (unit.empty()) fail("missing unit");
  return {v, unit};
}

// Prefix multiplier: "", k, M, G, T (10^3n) or Ki, Mi, Gi, Ti (2^10n). Returns the rest.
bool prefix(std::string_view& u, double& mult) {
  mult = 1;
  if (u.empty()) return true;
  static const struct { const char* p; double m; } table[] = {
      {"Ki", 1024.0}, {"Mi", 1048576.0}, {"Gi", 1073741824.0}, {"Ti", 1099511627776.0},
      {"k", 1e3}, {"K", 1e3}, {"M", 1e6}, {"G", 1e9}, {"T", 1e12}};
  for (const auto& e : table) {
    const std::string_view p(e.p);
    if (u.substr(0, p.size()) == p && u.size() > p.size()) {
      mult = e.m;
      u.remove_prefix(p.size());
      return true;
    }
  }
  return true;
}

}  // namespace

double parse_bytes(std::string_view text) {
  auto [v, unit] = split(text, "size", "\"8GiB\", \"210MB\", \"64B\"");
  double mult;
  prefix(unit, mult);
  if (unit == "B") {
    // Past 1 EiB the times derived from a size (Eq. 1) stop meaning anything; a typo.
    if (v * mult > kMaxBytes) throw std::invalid_argument("'" + std::string(text) + "' is not a valid size (larger than 1 EiB; expected e.g. \"8GiB\")");
    return v * mult;
  }
  if (unit == "b")  // "8Gb" is almost always a typo for "8GB": sizes are bytes only
    throw std::invalid_argument("'" + std::string(text) + "' is not a valid size (sizes are in bytes: expected B, e.g. \"8GiB\" or \"210MB\"; b = bit is only for bandwidths)");
  throw std::invalid_argument("'" + std::string(text) + "' is not a valid size (unknown unit; expected B with an optional k/M/G/T or Ki/Mi/Gi/Ti prefix, e.g. \"8GiB\", \"210MB\", \"64B\")");
}

double parse_bandwidth(std::string_view text) {
  auto [v, unit] = split(text, "bandwidth", "\"150MB/s\", \"1Gb/s\"");
  if (unit.size() < 3 || unit.substr(unit.size() - 2) != "/s")
    throw std::invalid_argument("'" + std::string(text) + "' is not a valid bandwidth (expected a size per second, e.g. \"150MB/s\" or \"1Gb/s\")");
  std::string_view u = unit.substr(0, unit.size() - 2);
  double mult;
  prefix(u, mult);
  double bytes;
  if (u == "B") bytes = v * mult;
  else if (u == "b") bytes = v * mult / 8;
  else throw std::invalid_argument("'" + std::string(text) + "' is not a valid bandwidth (unknown unit; expected e.g. \"150MB/s\" or \"1Gb/s\")");
  if (!(bytes > 0)) throw std::invalid_argument("'" + std::string(text) + "' is not a valid bandwidth (must be > 0; expected e.g. \"150MB/s\")");
  // Slower than 1 B/s, a block's transfer time (Eq. 1) overflows to infinity or close to
  // it, and every time printed after it is noise: surely a typo in the unit.
  if (bytes < 1) throw std::invalid_argument("'" + std::string(text) + "' is not a valid bandwidth (slower than 1 B/s; expected e.g. \"150MB/s\")");
  return bytes;
}

double parse_duration(std::string_view text) {
  auto [v, unit] = split(text, "duration", "\"8ms\", \"100us\", \"2s\"");
  double seconds;
  if (unit == "s") seconds = v;
  else if (unit == "ms") seconds = v * 1e-3;
  else if (unit == "us") seconds = v * 1e-6;
  else if (unit == "ns") seconds = v * 1e-9;
  else if (unit == "min") seconds = v * 60;
  else if (unit == "h") seconds = v * 3600;
  else throw std::invalid_argument("'" + std::string(text) + "' is not a valid duration (unknown unit; expected s, ms, us, ns, min or h)");
  if (seconds > kMaxSeconds) throw std::invalid_argument("'" + std::string(text) + "' is not a valid duration (longer than 1e9 s, about 32 years; expected e.g. \"2s\")");
  return seconds;
}

double parse_rate(std::string_view text) {
  auto [v, unit] = split(text, "rate", "\"10M/s\", \"500k/s\"");
  double mult;
  prefix(unit, mult);
  if (unit != "/s") throw std::invalid_argument("'" + std::string(text) + "' is not a valid rate (expected e.g. \"10M/s\")");
  if (!(v > 0)) throw std::invalid_argument("'" + std::string(text) + "' is not a valid rate (must be > 0; expected e.g. \"10M/s\")");
  return v * mult;
}

}  // namespace rayline::units
