#include "render/store/block_reader.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "common/error.hpp"

namespace rayline::engine {

namespace {
constexpr std::size_t kAlign = 4096;

struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};
}  // namespace

RawBlock read_block_uncached(const std::string& path, bool allow_direct) {
  RawBlock out;
  Fd f;
#ifdef O_DIRECT
  if (allow_direct) f.fd = ::open(path.c_str(), O_RDONLY | O_DIRECT | O_CLOEXEC);
#endif
  out.mode = f.fd >= 0 ? ReadMode::Direct : ReadMode::Buffered;
  if (f.fd < 0) f.fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (f.fd < 0) throw InputError(path, "file", std::string("cannot open block file: ") + std::strerror(errno));
  struct stat st {};
  if (::fstat(f.fd, &st) != 0) throw InputError(path, "file", std::string("cannot stat: ") + std::strerror(errno));
  const auto size = static_cast<std::uint64_t>(st.st_size);
  if (size < partition::kBlockHeaderBytes) throw InputError(path, "header", "truncated header (file too short)");
  const std::size_t cap = (size + kAlign - 1) / kAlign * kAlign;
  out.buffer = {static_cast<unsigned char*>(std::aligned_alloc(kAlign, cap)), std::free};
  if (!out.buffer) throw std::bad_alloc();
  std::uint64_t done = 0;
  while (done < size) {
    // O_DIRECT: aligned offsets and lengths; the last read may return less.
    const ssize_t r = ::pread(f.fd, out.buffer.get() + done, cap - done, static_cast<off_t>(done));
    if (r < 0 && errno == EINTR) continue;
    if (r < 0 && out.mode == ReadMode::Direct && errno == EINVAL && done == 0) {
      // The file system accepted O_DIRECT at open but not for reads: read buffered.
      ::close(f.fd);
      f.fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
      out.mode = ReadMode::Buffered;
      if (f.fd < 0) throw InputError(path, "file", std::string("cannot open block file: ") + std::strerror(errno));
      continue;
    }
    if (r < 0) throw InputError(path, "payload", std::string("read failed: ") + std::strerror(errno));
    if (r == 0) break;
    done += static_cast<std::uint64_t>(r);
  }
  if (out.mode == ReadMode::Buffered) ::posix_fadvise(f.fd, 0, 0, POSIX_FADV_DONTNEED);
  if (done < size) throw InputError(path, "payload", "file shrank while reading");
  out.file_bytes = size;
  out.header = partition::decode_block_header({out.buffer.get(), partition::kBlockHeaderBytes}, path);
  const std::uint64_t expect = partition::kBlockHeaderBytes + out.header.payload_bytes;
  if (size != expect)
    throw InputError(path, "payload_bytes",
                     "file has " + std::to_string(size) + " bytes, header says " + std::to_string(expect) +
                         (size < expect ? " (truncated block)" : " (trailing bytes)"));
  out.payload = {out.buffer.get() + partition::kBlockHeaderBytes, out.header.payload_bytes};
  if (partition::crc32_update(0, out.payload) != out.header.payload_crc32)
    throw InputError(path, "payload_crc32", "payload checksum mismatch (corrupted block)");
  return out;
}

}  // namespace rayline::engine
