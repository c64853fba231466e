#include "render/scene/spill_file.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <stdexcept>
#include <sys/mman.h>
#include <unistd.h>
#include <vector>

namespace rayline::scene {
namespace {

// An unnamed read-write file in `dir`, or -1.
int open_anonymous(const std::string& dir) {
  int fd = -1;
#ifdef O_TMPFILE
  fd = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd >= 0) return fd;
#endif
  std::string templ = dir + "/rayline-spill-XXXXXX";
  fd = ::mkostemp(templ.data(), O_CLOEXEC);
  if (fd < 0) return -1;
  ::unlink(templ.c_str());
  return fd;
}

}  // namespace

SpillFile::SpillFile() {
  std::vector<std::string> dirs;
  for (const char* env : {"RAYLINE_SPILL_DIR", "TMPDIR"})
    if (const char* v = std::getenv(env); v && *v) dirs.emplace_back(v);
  dirs.emplace_back("/var/tmp");
  dirs.emplace_back("/tmp");
  std::string tried;
  for (const auto& d : dirs) {
    fd_ = open_anonymous(d);
    if (fd_ >= 0) {
      dir_ = d;
      return;
    }
    tried += (tried.empty() ? "" : ", ") + d + " (" + std::strerror(errno) + ")";
  }
  throw std::runtime_error("cannot create a temporary file for mesh vertices; tried " + tried +
                           "; set RAYLINE_SPILL_DIR to a writable folder");
}

SpillFile::~SpillFile() {
  if (data_) ::munmap(data_, capacity_);
  if (fd_ >= 0) ::close(fd_);
}

void SpillFile::reserve(std::size_t bytes) {
  if (bytes <= capacity_) return;
  const std::size_t page = std::size_t(::sysconf(_SC_PAGESIZE));
  std::size_t cap = std::max<std::size_t>(capacity_ * 2, std::size_t(1) << 20);
  while (cap < bytes) cap *= 2;
  cap = (cap + page - 1) / page * page;
  auto fail = [&](const char* what) {
    throw std::runtime_error(std::string("mesh vertex spill file in ") + dir_ + ": " + what + " " +
                             std::to_string(cap >> 20) + " MiB failed: " + std::strerror(errno));
  };
  // Sparse: blocks are allocated by write(), which reports a full disk as ENOSPC. Only
  // written bytes are ever read through the mapping.
  if (::ftruncate(fd_, off_t(cap)) != 0) fail("sizing");
  void* m = data_ ? ::mremap(data_, capacity_, cap, MREMAP_MAYMOVE)
                  : ::mmap(nullptr, cap, PROT_READ, MAP_SHARED, fd_, 0);
  if (m == MAP_FAILED) fail("mapping");
  data_ = static_cast<unsigned char*>(m);
  capacity_ = cap;
}

void SpillFile::write(std::size_t offset, const void* bytes, std::size_t n) {
  reserve(offset + n);
  const auto* p = static_cast<const unsigned char*>(bytes);
  while (n > 0) {
    const ssize_t w = ::pwrite(fd_, p, n, off_t(offset));
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0)
      throw std::runtime_error(std::string("mesh vertex spill file in ") + dir_ + ": write failed: " +
                               std::strerror(w < 0 ? errno : ENOSPC) + " (set RAYLINE_SPILL_DIR to a folder with room)");
    p += w, offset += std::size_t(w), n -= std::size_t(w);
  }
}

void SpillFile::drop_resident() const {
  // A shared file mapping: MADV_DONTNEED only unmaps; the data stays in the file.
  if (data_) ::madvise(data_, capacity_, MADV_DONTNEED);
}

}  // namespace rayline::scene
