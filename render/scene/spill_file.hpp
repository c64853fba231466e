// Disk-backed scratch storage for the indexed text mesh readers (OBJ, OFF, ASCII PLY).
//
// Text formats list every vertex before (or among) the faces that index them, so a
// streaming reader has to keep the vertices somewhere while it reads the faces. Keeping
// them in a std::vector makes the reader's memory grow with the mesh; instead they go to
// an anonymous temporary file (O_TMPFILE, or mkstemp + unlink: it has no name and
// disappears with the process, even on a crash) that is memory-mapped MAP_SHARED. Its
// pages belong to the page cache, which the kernel writes back and evicts under memory
// pressure, so a mesh whose vertices do not fit in RAM still reads (at disk speed), and
// `drop_resident()` takes them out of this process's resident set between batches.
//
// Appends go through a small buffer and pwrite() (no page faults on write, no page
// zeroing; written pages sit in the page cache, not in the resident set); reads go
// through a read-only shared mapping, where the kernel maps neighbouring pages in
// batches (fault-around).
//
// The file lives in $RAYLINE_SPILL_DIR, else $TMPDIR, else /var/tmp, else /tmp (the
// first that accepts a file). Point it at a disk when /tmp is a tmpfs (RAM).
// A full disk is a clean std::runtime_error from pwrite(), never a SIGBUS.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <type_traits>

namespace rayline::scene {

class SpillFile {
 public:
  SpillFile();
  ~SpillFile();
  SpillFile(const SpillFile&) = delete;
  SpillFile& operator=(const SpillFile&) = delete;

  // Makes the file and its read-only mapping at least `bytes` long (grows geometrically;
  // may move data()). Throws std::runtime_error when mapping fails.
  void reserve(std::size_t bytes);
  // Writes `n` bytes at `offset` (reserving as needed). Throws std::runtime_error when
  // the disk is full.
  void write(std::size_t offset, const void* bytes, std::size_t n);
  const unsigned char* data() const { return data_; }
  std::size_t capacity() const { return capacity_; }
  const std::string& directory() const { return dir_; }
  // Drops the mapped pages from the resident set; contents are kept (page cache / disk).
  void drop_resident() const;

 private:
  int fd_ = -1;
  unsigned char* data_ = nullptr;
  std::size_t capacity_ = 0;
  std::string dir_;
};

// An append-only array of trivially copyable T on a SpillFile. The last (up to 16 K)
// elements live in a heap buffer until it fills; indexing reads either place.
template <class T>
class SpillArray {
  static_assert(std::is_trivially_copyable_v<T>);
  static constexpr std::size_t kBuffer = std::size_t(1) << 14;

 public:
  SpillArray() : buf_(new T[kBuffer]) {}
  void push_back(const T& v) {
    buf_[pending_++] = v;
    if (pending_ == kBuffer) flush();
  }
  const T& operator[](std::size_t i) const { return i < flushed_ ? ptr_[i] : buf_[i - flushed_]; }
  std::size_t size() const { return flushed_ + pending_; }
  // Sizes the file for `n` elements up front (no allocation on disk: the file is sparse).
  void reserve(std::size_t n) {
    file_.reserve(n * sizeof(T));
    ptr_ = reinterpret_cast<const T*>(file_.data());
  }
  void drop_resident() const { file_.drop_resident(); }

 private:
  void flush() {
    file_.write(flushed_ * sizeof(T), buf_.get(), pending_ * sizeof(T));
    ptr_ = reinterpret_cast<const T*>(file_.data());
    flushed_ += pending_;
    pending_ = 0;
  }
  SpillFile file_;
  std::unique_ptr<T[]> buf_;
  const T* ptr_ = nullptr;
  std::size_t flushed_ = 0, pending_ = 0;
};

}  // namespace rayline::scene
