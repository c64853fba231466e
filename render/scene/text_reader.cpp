#include "render/scene/text_reader.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "common/error.hpp"

namespace rayline::scene {
namespace {
constexpr std::size_t kInitialBuffer = std::size_t(1) << 20;
constexpr std::size_t kMinBuffer = 4096;
constexpr std::size_t kMaxLine = std::size_t(64) << 20;
}  // namespace

LineReader::LineReader(const std::string& path, std::uint64_t offset, std::uint64_t first_line)
    : path_(path), line_(first_line - 1) {
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);  // a FIFO must not block
  if (fd_ < 0) throw InputError(path, "", std::string("cannot open mesh file: ") + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd_);
    throw InputError(path, "", "not a regular file");
  }
  ::posix_fadvise(fd_, 0, 0, POSIX_FADV_SEQUENTIAL);
  if (offset > 0 && ::lseek(fd_, off_t(offset), SEEK_SET) < 0) {
    ::close(fd_);
    throw InputError(path, "", std::string("cannot seek in mesh file: ") + std::strerror(errno));
  }
  // A small file gets a buffer of its size, not 1 MiB of zeroed memory (a mesh is read
  // two or three times: stats, then the partitioner's passes).
  const auto left = static_cast<std::uint64_t>(st.st_size) > offset ? static_cast<std::uint64_t>(st.st_size) - offset : 0;
  buf_.resize(std::size_t(std::clamp<std::uint64_t>(left + 1, kMinBuffer, kInitialBuffer)));
}

LineReader::~LineReader() {
  if (fd_ >= 0) ::close(fd_);
}

// Moves the unread tail to the front and reads more; false when nothing more came.
bool LineReader::fill() {
  if (eof_) return false;
  if (begin_ > 0) {
    std::memmove(buf_.data(), buf_.data() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  if (end_ == buf_.size()) {
    if (buf_.size() >= kMaxLine)
      throw InputError(path_, "line " + std::to_string(line_ + 1), "line longer than 64 MiB (not a text mesh?)");
    buf_.resize(buf_.size() * 2);
  }
  for (;;) {
    const ssize_t n = ::read(fd_, buf_.data() + end_, buf_.size() - end_);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw InputError(path_, "line " + std::to_string(line_ + 1), std::string("read failed: ") + std::strerror(errno));
    if (n == 0) {
      eof_ = true;
      return false;
    }
    end_ += std::size_t(n);
    return true;
  }
}

bool LineReader::next(std::string_view& line) {
  std::size_t scanned = begin_;  // bytes already known to hold no '\n'
  for (;;) {
    const char* base = buf_.data();
    if (const void* nl = std::memchr(base + scanned, '\n', end_ - scanned)) {
      const std::size_t at = std::size_t(static_cast<const char*>(nl) - base);
      std::size_t len = at - begin_;
      if (len > 0 && base[begin_ + len - 1] == '\r') --len;
      line = std::string_view(base + begin_, len);
      begin_ = at + 1;
      ++line_;
      return true;
    }
    const std::size_t pending = end_ - begin_;
    if (!fill()) {
      if (begin_ == end_) return false;  // clean end of file
      std::size_t len = end_ - begin_;   // last line without '\n'
      if (buf_[begin_ + len - 1] == '\r') --len;
      line = std::string_view(buf_.data() + begin_, len);
      begin_ = end_;
      ++line_;
      return true;
    }
    scanned = begin_ + pending;  // fill() moved the tail to the front
  }
}

std::string quote_token(std::string_view t) {
  std::string s = "'";
  for (std::size_t i = 0; i < t.size() && i < 40; ++i) {
    const unsigned char c = static_cast<unsigned char>(t[i]);
    if (c >= 0x20 && c < 0x7f) s += char(c);
    else {
      static const char* hex = "0123456789abcdef";
      s += "\\x", s += hex[c >> 4], s += hex[c & 15];
    }
  }
  if (t.size() > 40) s += "...";
  return s + "'";
}

}  // namespace rayline::scene
