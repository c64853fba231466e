// The SVG chart writer of `rayline report` (apps/report/svg_chart.hpp).
#include "apps/report/svg_chart.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace rayline::report {

std::string escape_xml(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 && c != '\t' && c != '\n')
          out += "\xEF\xBF\xBD";
        else
          out += c;
    }
  }
  return out;
}

double LinearScale::operator()(double v) const {
  if (d1 == d0) return r0;
  return r0 + (v - d0) / (d1 - d0) * (r1 - r0);
}

Ticks nice_ticks(double lo, double hi, int max_ticks) {
  if (!std::isfinite(lo) || !std::isfinite(hi)) lo = hi = 0;
  if (hi < lo) std::swap(lo, hi);
  if (hi - lo <= std::abs(lo) * 1e-9) hi = lo + (lo == 0 ? 1 : std::abs(lo) * 0.1);  // a range a step can cover
  max_ticks = std::max(max_ticks, 1);
  const double raw = (hi - lo) / max_ticks;
  if (!std::isfinite(raw) || raw <= 0) return Ticks{{lo, hi}, hi - lo};
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (const double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * mag;
    if (step * max_ticks >= (hi - lo) * (1 - 1e-12)) break;
  }
  Ticks t;
  t.step = step;
  const double first = std::floor(lo / step + 1e-9) * step;
  for (int i = 0; i <= 2 * max_ticks + 2; ++i) {  // bounded, whatever rounding does
    const double v = first + i * step;
    t.values.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
    if (v >= hi - step * 1e-9) break;
  }
  return t;
}

namespace {

struct Suffix {
  double divisor;
  const char* name;
};

// The SI suffix for |v|: none below 1000, then k, M, G, T, P.
Suffix si_suffix(double v) {
  static constexpr Suffix kSuffixes[] = {{1e15, "P"}, {1e12, "T"}, {1e9, "G"}, {1e6, "M"}, {1e3, "k"}};
  for (const Suffix& s : kSuffixes)
    if (std::abs(v) >= s.divisor * (1 - 1e-12)) return s;
  return {1, ""};
}

// `v` with `decimals` decimals, trailing zeros (and a trailing point) removed, no "-0".
std::string fixed(double v, int decimals) {
  char buf[64];
  if (!std::isfinite(v) || std::abs(v) >= 1e15) {  // too long in full: an exponent
    std::snprintf(buf, sizeof buf, "%.3g", v);
    return buf;
  }
  std::snprintf(buf, sizeof buf, "%.*f", std::clamp(decimals, 0, 12), v);
  std::string s = buf;
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  if (s == "-0") s = "0";
  return s;
}

// 3 significant digits, no exponent for 0.001 <= |v| < 1000.
std::string sig3(double v) {
  if (v == 0) return "0";
  const double a = std::abs(v);
  if (a < 1e-3 || a >= 1e15) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", v);
    return buf;
  }
  const int digits = static_cast<int>(std::floor(std::log10(a))) + 1;
  return fixed(v, 3 - digits);
}

std::string with_si(double v) {
  const Suffix s = si_suffix(v);
  return sig3(v / s.divisor) + s.name;
}

}  // namespace

std::string format_si(double value) { return std::isfinite(value) ? with_si(value) : "n/a"; }

std::string format_tick(double value, double step) {
  if (std::abs(value) < std::abs(step) * 1e-9) return "0";
  const Suffix s = si_suffix(value);
  const double rel = std::abs(step) / s.divisor;
  const int decimals = rel > 0 ? std::max(0, -static_cast<int>(std::floor(std::log10(rel) + 1e-9))) : 0;
  return fixed(value / s.divisor, decimals) + s.name;
}

std::string format_quantity(double value, std::string_view unit) {
  if (!std::isfinite(value)) return "n/a";
  if (unit == "%") return sig3(value * 100) + " %";
  if (unit == "s") {
    const double a = std::abs(value);
    if (a > 0 && a < 1e-3) return sig3(value * 1e6) + " µs";
    if (a > 0 && a < 1) return sig3(value * 1e3) + " ms";
    return (a >= 1000 && a < 1e15 ? fixed(value, 0) : sig3(value)) + " s";
  }
  if (unit == "B") {
    const Suffix s = si_suffix(value);
    return sig3(value / s.divisor) + " " + s.name + "B";
  }
  if (unit.empty()) {
    if (value == std::floor(value) && std::abs(value) < 1e15) return fixed(value, 0);
    return with_si(value);
  }
  // As the command line prints rates (apps/cli_common format_rate): "3.67 M rays/s".
  const Suffix s = si_suffix(value);
  return sig3(value / s.divisor) + " " + (*s.name == '\0' ? std::string() : std::string(s.name) + " ") + std::string(unit);
}

namespace {

// A coordinate; one that overflowed (a value near the largest double) is drawn at 0.
std::string num(double v) { return std::isfinite(v) ? fixed(v, 1) : "0"; }

// Markup of one <svg> element, written in order.
class Svg {
 public:
  Svg(const ChartFrame& f, int height) : f_(f), height_(height) {
    out_ << "<svg id=\"" << escape_xml(f.id) << "\" class=\"chart\" xmlns=\"http://www.w3.org/2000/svg\" width=\""
         << f.width << "\" height=\"" << height << "\" viewBox=\"0 0 " << f.width << ' ' << height
         << "\" role=\"img\" aria-labelledby=\"" << escape_xml(f.id) << "-title\">"
         << "<title id=\"" << escape_xml(f.id) << "-title\">" << escape_xml(f.title) << "</title>\n";
    text(f.left, 18, f.title, "start", "font-weight=\"bold\" font-size=\"14\"");
    if (!f.y_label.empty())
      out_ << "<text transform=\"translate(14," << num(top() + plot_height() / 2)
           << ") rotate(-90)\" text-anchor=\"middle\" font-size=\"12\">" << escape_xml(f.y_label) << "</text>\n";
    if (!f.x_label.empty()) text(f.left + plot_width() / 2.0, height - 8, f.x_label, "middle");
  }

  double left() const { return f_.left; }
  double top() const { return f_.top; }
  double plot_width() const { return std::max(1, f_.width - f_.left - f_.right); }
  double plot_height() const { return std::max(1, height_ - f_.top - f_.bottom); }
  double bottom() const { return top() + plot_height(); }

  void rect(double x, double y, double w, double h, std::string_view fill, std::string_view tip = "",
            std::string_view extra = "") {
    out_ << "<rect x=\"" << num(x) << "\" y=\"" << num(y) << "\" width=\"" << num(std::max(w, 0.0)) << "\" height=\""
         << num(std::max(h, 0.0)) << "\" fill=\"" << fill << '"';
    if (!extra.empty()) out_ << ' ' << extra;
    if (tip.empty())
      out_ << "/>\n";
    else
      out_ << "><title>" << escape_xml(tip) << "</title></rect>\n";
  }
  void line(double x1, double y1, double x2, double y2, std::string_view stroke) {
    out_ << "<line x1=\"" << num(x1) << "\" y1=\"" << num(y1) << "\" x2=\"" << num(x2) << "\" y2=\"" << num(y2)
         << "\" stroke=\"" << stroke << "\"/>\n";
  }
  void text(double x, double y, std::string_view s, std::string_view anchor = "start", std::string_view extra = "") {
    out_ << "<text x=\"" << num(x) << "\" y=\"" << num(y) << "\" text-anchor=\"" << anchor << '"'
         << (extra.empty() ? "" : " ") << extra << '>' << escape_xml(s) << "</text>\n";
  }
  void polyline(const std::vector<std::pair<double, double>>& points, std::string_view stroke) {
    out_ << "<polyline fill=\"none\" stroke-width=\"2\" stroke=\"" << stroke << "\" points=\"";
    for (const auto& [x, y] : points) out_ << num(x) << ',' << num(y) << ' ';
    out_ << "\"/>\n";
  }
  void raw(std::string_view markup) { out_ << markup; }

  // Value axis on the left: grid lines and tick labels (with `unit` after the top one).
  void y_axis(const Ticks& t, const LinearScale& y) {
    for (const double v : t.values) {
      line(left(), y(v), left() + plot_width(), y(v), "#e9ecef");
      text(left() - 6, y(v) + 4, format_tick(v, t.step), "end");
    }
    line(left(), top(), left(), bottom(), "#495057");
  }
  // Numeric axis along the bottom.
  void x_axis(const Ticks& t, const LinearScale& x) {
    line(left(), bottom(), left() + plot_width(), bottom(), "#495057");
    for (const double v : t.values) {
      if (x(v) < left() - 0.5 || x(v) > left() + plot_width() + 0.5) continue;
      line(x(v), bottom(), x(v), bottom() + 4, "#495057");
      text(x(v), bottom() + 17, format_tick(v, t.step), "middle");
    }
  }
  // Coloured squares and names in a row under the title.
  void legend(const std::vector<std::pair<std::string, std::string>>& entries) {
    double x = left();
    for (const auto& [name, fill] : entries) {
      rect(x, 26, 10, 10, fill);
      text(x + 14, 35, name);
      x += 24 + 7.0 * static_cast<double>(name.size());
    }
  }
  void series_legend(const std::vector<Series>& series) {
    std::vector<std::pair<std::string, std::string>> e;
    for (const Series& s : series) e.emplace_back(s.name, s.colour);
    if (e.size() > 1) legend(e);
  }

  std::string finish() {
    out_ << "</svg>\n";
    return out_.str();
  }

 private:
  const ChartFrame& f_;
  int height_;
  std::ostringstream out_;
};

double max_of(const std::vector<Series>& series) {
  double m = 0;
  for (const Series& s : series)
    for (const double v : s.values)
      if (std::isfinite(v)) m = std::max(m, v);
  return m;
}

// A label cut to about `n` bytes (never inside a UTF-8 character), with an ellipsis when cut.
std::string clip(const std::string& s, std::size_t n) {
  if (s.size() <= n || n < 2) return s;
  std::size_t end = n - 1;
  while (end > 0 && (static_cast<unsigned char>(s[end]) & 0xC0) == 0x80) --end;
  return s.substr(0, end) + "…";
}

}  // namespace

std::string line_chart(const ChartFrame& frame, const std::vector<double>& x, const std::vector<Series>& series,
                       std::string_view y_unit) {
  Svg svg(frame, frame.height);
  const double x0 = x.empty() ? 0 : std::min(0.0, *std::min_element(x.begin(), x.end()));  // from 0 when it can
  const double x1 = x.empty() ? 1 : *std::max_element(x.begin(), x.end());
  const Ticks xt = nice_ticks(x0, x1, 8);
  const Ticks yt = nice_ticks(0, max_of(series), 5);
  const LinearScale xs{x0, x1 > x0 ? x1 : x0 + 1, svg.left(), svg.left() + svg.plot_width()};
  const LinearScale ys{yt.values.front(), yt.values.back(), svg.bottom(), svg.top()};
  svg.y_axis(yt, ys);
  svg.x_axis(xt, xs);
  svg.series_legend(series);
  for (const Series& s : series) {
    std::vector<std::pair<double, double>> points;
    for (std::size_t i = 0; i < std::min(x.size(), s.values.size()); ++i) {
      points.emplace_back(xs(x[i]), ys(s.values[i]));
      svg.rect(xs(x[i]) - 2.5, ys(s.values[i]) - 2.5, 5, 5, s.colour,
               s.name + ": " + format_quantity(s.values[i], y_unit) + " at " + format_tick(x[i], xt.step / 10));
    }
    svg.polyline(points, s.colour);
  }
  return svg.finish();
}

std::string bar_chart(const ChartFrame& frame, const std::vector<std::string>& categories,
                      const std::vector<Series>& series, std::string_view y_unit) {
  Svg svg(frame, frame.height);
  const Ticks yt = nice_ticks(0, max_of(series), 5);
  const LinearScale ys{yt.values.front(), yt.values.back(), svg.bottom(), svg.top()};
  svg.y_axis(yt, ys);
  svg.line(svg.left(), svg.bottom(), svg.left() + svg.plot_width(), svg.bottom(), "#495057");
  svg.series_legend(series);
  const double slot = svg.plot_width() / std::max<std::size_t>(1, categories.size());
  const double bar = slot * 0.8 / std::max<std::size_t>(1, series.size());
  for (std::size_t c = 0; c < categories.size(); ++c) {
    const double x = svg.left() + c * slot + slot * 0.1;
    for (std::size_t s = 0; s < series.size(); ++s) {
      const double v = c < series[s].values.size() ? series[s].values[c] : 0;
      svg.rect(x + s * bar, ys(v), bar, svg.bottom() - ys(v), series[s].colour,
               categories[c] + (series.size() > 1 ? ", " + series[s].name : "") + ": " + format_quantity(v, y_unit));
    }
    svg.text(x + slot * 0.4, svg.bottom() + 17, clip(categories[c], static_cast<std::size_t>(std::max(4.0, slot / 7))),
             "middle");
  }
  return svg.finish();
}

std::string histogram(const ChartFrame& frame, const std::vector<double>& edges, const std::vector<double>& counts,
                      std::string_view x_unit) {
  Svg svg(frame, frame.height);
  const double lo = edges.empty() ? 0 : edges.front(), hi = edges.size() < 2 ? lo + 1 : edges.back();
  const Ticks xt = nice_ticks(lo, hi, 8);
  double top = 0;
  for (const double c : counts) top = std::max(top, c);
  const Ticks yt = nice_ticks(0, top, 5);
  const LinearScale xs{lo, hi, svg.left(), svg.left() + svg.plot_width()};
  const LinearScale ys{yt.values.front(), yt.values.back(), svg.bottom(), svg.top()};
  svg.y_axis(yt, ys);
  svg.x_axis(xt, xs);
  for (std::size_t i = 0; i < counts.size() && i + 1 < edges.size(); ++i)
    svg.rect(xs(edges[i]) + 0.5, ys(counts[i]), xs(edges[i + 1]) - xs(edges[i]) - 1, svg.bottom() - ys(counts[i]),
             colour::kLine,
             format_quantity(edges[i], x_unit) + " – " + format_quantity(edges[i + 1], x_unit) + ": " +
                 format_quantity(counts[i], ""));
  return svg.finish();
}

namespace {

// Each row's sum over the series (negative values count as 0).
std::vector<double> row_totals(std::size_t rows, const std::vector<Series>& series) {
  std::vector<double> totals(rows, 0.0);
  for (const Series& s : series)
    for (std::size_t r = 0; r < rows && r < s.values.size(); ++r) totals[r] += std::max(0.0, s.values[r]);
  return totals;
}

// The tooltip of one segment: its value, or its share (and value unless that is a share).
std::string segment_tip(const std::string& row, const Series& s, double value, double share, bool shares,
                        std::string_view unit) {
  std::string tip = row + ", " + s.name + ": ";
  if (!shares) return tip + format_quantity(value, unit);
  tip += format_quantity(share / 100, "%");
  return unit == "%" ? tip : tip + " (" + format_quantity(value, unit) + ")";
}

}  // namespace

std::string stacked_hbars(const ChartFrame& frame, const std::vector<std::string>& rows,
                          const std::vector<Series>& series, bool shares, std::string_view value_unit) {
  constexpr double kRow = 16;
  const int height = std::max(frame.height, frame.top + frame.bottom + static_cast<int>(kRow * rows.size()));
  Svg svg(frame, height);
  const std::vector<double> totals = row_totals(rows.size(), series);
  const double widest = totals.empty() ? 0 : *std::max_element(totals.begin(), totals.end());
  const Ticks xt = shares ? nice_ticks(0, 100, 5) : nice_ticks(0, widest, 6);
  const LinearScale xs{xt.values.front(), xt.values.back(), svg.left(), svg.left() + svg.plot_width()};
  for (const double v : xt.values) svg.line(xs(v), svg.top(), xs(v), svg.bottom(), "#e9ecef");
  svg.x_axis(xt, xs);
  svg.series_legend(series);
  const double band = svg.plot_height() / std::max<std::size_t>(1, rows.size());
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const double y = svg.top() + r * band;
    svg.text(svg.left() - 6, y + band / 2 + 4, clip(rows[r], static_cast<std::size_t>(svg.left() / 6.5)), "end",
             "font-size=\"11\"");
    double at = 0;  // where the next segment starts, in axis units
    for (const Series& s : series) {
      const double v = r < s.values.size() ? std::max(0.0, s.values[r]) : 0;
      double w = shares ? (totals[r] > 0 ? 100 * v / totals[r] : 0) : v;
      if (!std::isfinite(w)) w = 0;
      svg.rect(xs(at), y + band * 0.15, xs(at + w) - xs(at), band * 0.7, s.colour,
               segment_tip(rows[r], s, v, w, shares, value_unit));
      at += w;
    }
  }
  svg.line(svg.left(), svg.top(), svg.left(), svg.bottom(), "#495057");
  return svg.finish();
}

std::string gantt(const ChartFrame& frame, const std::vector<std::string>& rows, const std::vector<GanttBar>& bars,
                  double t0, double t1) {
  constexpr double kRow = 26;
  const int height = std::max(frame.height, frame.top + frame.bottom + static_cast<int>(kRow * rows.size()));
  Svg svg(frame, height);
  if (t1 <= t0) t1 = t0 + 1;
  const Ticks xt = nice_ticks(t0, t1, 8);
  const LinearScale xs{t0, t1, svg.left(), svg.left() + svg.plot_width()};
  for (const double v : xt.values)
    if (v >= t0 && v <= t1) svg.line(xs(v), svg.top(), xs(v), svg.bottom(), "#e9ecef");
  svg.x_axis(xt, xs);
  svg.legend({{"planned", colour::kPlanned}, {"actual E-job", colour::kBusy}, {"actual T-job", colour::kTransfer}});
  const double band = svg.plot_height() / std::max<std::size_t>(1, rows.size());
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const double y = svg.top() + r * band;
    svg.text(svg.left() - 6, y + band / 2 + 4, clip(rows[r], static_cast<std::size_t>(svg.left() / 6.5)), "end",
             "font-size=\"11\"");
    svg.line(svg.left(), y + band, svg.left() + svg.plot_width(), y + band, "#f1f3f5");
  }
  for (const GanttBar& b : bars) {
    if (b.row >= rows.size() || b.end < t0 || b.start > t1) continue;
    const double x0 = xs(std::max(b.start, t0)), x1 = xs(std::min(b.end, t1));
    const double y = svg.top() + b.row * band + (b.planned ? band * 0.08 : band * 0.5);
    svg.rect(x0, y, std::max(x1 - x0, 0.6), band * 0.42, b.colour, b.tip, R"(stroke="#fff" stroke-width="0.5")");
  }
  svg.line(svg.left(), svg.top(), svg.left(), svg.bottom(), "#495057");
  return svg.finish();
}

}  // namespace rayline::report
