// Fast line and token reading for the text mesh formats (OBJ, OFF, ASCII PLY, ASCII STL).
// LineReader reads the file with read() into one buffer (1 MiB, or the file's size if
// smaller; grown only for longer lines, up to 64 MiB) and hands out lines as string_views
// into it: no iostreams, no per-line allocation, and the file's pages stay in the page
// cache, not in this process.
// Tokens parses numbers with std::from_chars (correctly rounded, locale-free).
#pragma once
#include <charconv>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace rayline::scene {

class LineReader {
 public:
  // Starts at byte `offset`, calling that line number `first_line`. Throws
  // InputError(path, "", ...) when the file cannot be opened.
  LineReader(const std::string& path, std::uint64_t offset = 0, std::uint64_t first_line = 1);
  ~LineReader();
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;

  // The next line without its "\n" / "\r\n"; false at the end of the file. The view is
  // valid until the next call. Throws InputError(path, "line N", ...) for a line longer
  // than 64 MiB or a read error.
  bool next(std::string_view& line);
  // Number of the line last returned by next() (1-based).
  std::uint64_t line() const { return line_; }
  // "line N", for InputError fields.
  std::string where() const { return "line " + std::to_string(line_); }
  const std::string& path() const { return path_; }

 private:
  bool fill();
  std::string path_;
  int fd_ = -1;
  std::vector<char> buf_;
  std::size_t begin_ = 0, end_ = 0;
  bool eof_ = false;
  std::uint64_t line_ = 0;
};

inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

// Whitespace-separated tokens of one line. With `hash_comments`, '#' ends the line.
struct Tokens {
  const char* p;
  const char* e;
  bool hash_comments = false;

  explicit Tokens(std::string_view line, bool comments = false)
      : p(line.data()), e(line.data() + line.size()), hash_comments(comments) {}

  void skip_blanks() {
    while (p != e && is_blank(*p)) ++p;
    if (hash_comments && p != e && *p == '#') p = e;
  }
  bool at_end() {
    skip_blanks();
    return p == e;
  }
  std::string_view word() {
    skip_blanks();
    const char* b = p;
    while (p != e && !is_blank(*p)) ++p;
    return {b, std::size_t(p - b)};
  }
  void skip_word() { (void)word(); }
  // A number followed by a blank, the end of the line (or '#' with comments). False and
  // nothing consumed otherwise. Values beyond float range become ±inf or 0 (callers
  // reject non-finite coordinates). Always the correctly rounded float, as from_chars.
  bool number(float& out) {
    skip_blanks();
    // Fast path (Clinger): [-+]digits[.digits] with an integer mantissa m ≤ 2^24 and at
    // most 10 fraction digits is exactly m / 10^k, two floats that are exact, so one
    // IEEE division rounds correctly. Anything else (exponents, long mantissas, inf,
    // nan) goes to std::from_chars.
    static constexpr float kPow10[] = {1e0f, 1e1f, 1e2f, 1e3f, 1e4f, 1e5f, 1e6f, 1e7f, 1e8f, 1e9f, 1e10f};
    const char* q = p;
    const bool neg = q != e && *q == '-';
    if (q != e && (*q == '-' || *q == '+')) ++q;
    std::uint32_t m = 0;
    int digits = 0, frac = -1;
    for (; q != e; ++q) {
      const unsigned d = unsigned(*q) - '0';
      if (d < 10) {
        if (m > (1u << 24) / 10) break;  // might pass 2^24: slow path
        m = m * 10 + d, ++digits;
        if (frac >= 0) ++frac;
      } else if (*q == '.' && frac < 0) {
        frac = 0;
      } else {
        break;
      }
    }
    if (digits > 0 && m <= (1u << 24) && frac <= 10 && delimited(q)) {
      const float v = frac > 0 ? float(m) / kPow10[frac] : float(m);
      out = neg ? -v : v;
      p = q;
      return true;
    }
    return slow_number(out);
  }
  bool slow_number(float& out) {
    const char* b = p;
    if (b != e && *b == '+') ++b;
    auto r = std::from_chars(b, e, out);
    if (r.ec == std::errc::result_out_of_range) {
      double d;
      r = std::from_chars(b, e, d);
      out = static_cast<float>(d);
    }
    if (r.ec != std::errc() || !delimited(r.ptr)) return false;
    p = r.ptr;
    return true;
  }
  // An integer; `stop` is one extra delimiter allowed after it (OBJ's '/').
  bool integer(std::int64_t& out, char stop = ' ') {
    skip_blanks();
    const char* q = p;
    const bool neg = q != e && *q == '-';
    if (q != e && (*q == '-' || *q == '+')) ++q;
    const char* first = q;
    std::int64_t v = 0;
    for (; q != e && q - first < 18; ++q) {  // 18 digits cannot overflow
      const unsigned d = unsigned(*q) - '0';
      if (d >= 10) break;
      v = v * 10 + d;
    }
    if (q == first) return false;
    if (q != e && unsigned(*q) - '0' < 10) {  // longer: let from_chars detect overflow
      const auto r = std::from_chars(first, e, v);
      if (r.ec != std::errc()) return false;
      q = r.ptr;
    }
    if (!(delimited(q) || *q == stop)) return false;
    out = neg ? -v : v;
    p = q;
    return true;
  }
  bool delimited(const char* q) const { return q == e || is_blank(*q) || (hash_comments && *q == '#'); }
};

// Case-insensitive comparison of an ASCII keyword.
inline bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    char x = a[i], y = b[i];
    if (x >= 'A' && x <= 'Z') x = char(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = char(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

// A token quoted for messages (shortened, control characters escaped).
std::string quote_token(std::string_view t);

}  // namespace rayline::scene
