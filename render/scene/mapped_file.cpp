#include "render/scene/mapped_file.hpp"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "common/error.hpp"

namespace rayline::scene {

MappedFile::MappedFile(const std::string& path) : path_(path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);  // a FIFO must not block
  if (fd < 0) throw InputError(path, "", std::string("cannot open mesh file: ") + std::strerror(errno));
  struct stat st{};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw InputError(path, "", "not a regular file");
  }
  size_ = static_cast<std::size_t>(st.st_size);
  if (size_ > 0) {
    void* m = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
    if (m == MAP_FAILED) {
      const int err = errno;
      ::close(fd);
      throw InputError(path, "", std::string("cannot map mesh file: ") + std::strerror(err));
    }
    data_ = static_cast<const unsigned char*>(m);
  }
  ::close(fd);
}

MappedFile::~MappedFile() {
  if (data_) ::munmap(const_cast<unsigned char*>(data_), size_);
}

void MappedFile::advise_sequential() const {
  if (data_) ::madvise(const_cast<unsigned char*>(data_), size_, MADV_SEQUENTIAL);
}

void MappedFile::release(const unsigned char* from, const unsigned char* to) const {
  if (!data_) return;
  if (!from) from = data_;
  if (!to) to = data_ + size_;
  const std::size_t page = std::size_t(::sysconf(_SC_PAGESIZE));
  const std::size_t a = (std::size_t(from - data_) + page - 1) / page * page;  // inwards
  const std::size_t b = to == data_ + size_ ? size_ : std::size_t(to - data_) / page * page;
  if (b > a) ::madvise(const_cast<unsigned char*>(data_) + a, b - a, MADV_DONTNEED);
}

}  // namespace rayline::scene
