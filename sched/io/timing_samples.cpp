#include "sched/io/timing_samples.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <string_view>

#include "common/error.hpp"
#include "common/input_file.hpp"

namespace rayline {

namespace {

constexpr int kColumns = 3 + kDataKindCount;  // device, job_type, kinds..., duration_s

std::string_view column_name(int c) {
  if (c == 0) return "device";
  if (c == 1) return "job_type";
  if (c == kColumns - 1) return "duration_s";
  return kDataKindNames[static_cast<std::size_t>(c - 2)];
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    out.push_back(trim(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

}  // namespace

std::vector<TimingSample> read_timing_samples_csv(const std::string& path, const DeviceGraph& g) {
  std::ifstream in = open_input(path, "timing samples file");

  auto field = [](long line, int col) {
    return "line " + std::to_string(line) + " column " + std::string(column_name(col));
  };

  std::vector<TimingSample> out;
  std::string raw;
  long line_no = 0;
  bool have_header = false;
  while (std::getline(in, raw)) {
    ++line_no;
    const std::string_view line = trim(raw);
    if (line.empty() || line.front() == '#') continue;
    const auto cells = split(line);
    const std::string at_line = "line " + std::to_string(line_no);
    if (cells.size() != static_cast<std::size_t>(kColumns))
      throw InputError(path, at_line,
                       "expected " + std::to_string(kColumns) + " columns, found " + std::to_string(cells.size()));

    if (!have_header) {
      for (int c = 0; c < kColumns; ++c)
        if (cells[static_cast<std::size_t>(c)] != column_name(c))
          throw InputError(path, field(line_no, c),
                           "header must be device,job_type,SceneData,RayQueue,ShadowRayQueue,Framebuffer,Generic,"
                           "duration_s; found '" + std::string(cells[static_cast<std::size_t>(c)]) + "'");
      have_header = true;
      continue;
    }

    TimingSample s;
    s.device = g.find_compute(cells[0]);
    if (s.device == kNone)
      throw InputError(path, field(line_no, 0), "unknown compute device '" + std::string(cells[0]) + "'");
    s.type = g.job_type(cells[1]);
    if (s.type == kNone)
      throw InputError(path, field(line_no, 1), "unknown job type '" + std::string(cells[1]) + "'");

    for (int k = 0; k < kDataKindCount; ++k) {
      const int c = 2 + k;
      const std::string_view cell = cells[static_cast<std::size_t>(c)];
      Bytes b = 0;
      const auto [ptr, ec] = std::from_chars(cell.data(), cell.data() + cell.size(), b);
      if (cell.empty() || ec != std::errc{} || ptr != cell.data() + cell.size())
        throw InputError(path, field(line_no, c),
                         "expected a non-negative integer byte count, found '" + std::string(cell) + "'");
      if (b > 0) s.inputs.push_back({static_cast<DataKind>(k), b});
    }

    const int dc = kColumns - 1;
    const std::string_view cell = cells[static_cast<std::size_t>(dc)];
    double t = 0;
    const auto [ptr, ec] = std::from_chars(cell.data(), cell.data() + cell.size(), t);
    if (cell.empty() || ec != std::errc{} || ptr != cell.data() + cell.size())
      throw InputError(path, field(line_no, dc), "expected a number of seconds, found '" + std::string(cell) + "'");
    if (!std::isfinite(t) || t < 0) throw InputError(path, field(line_no, dc), "duration must be finite and >= 0");
    s.duration = t;
    out.push_back(std::move(s));
  }
  if (!have_header) throw InputError(path, "line 1", "missing header line");
  return out;
}

}  // namespace rayline
