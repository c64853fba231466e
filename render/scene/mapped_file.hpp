// A read-only memory mapping of a whole file, for the mesh readers that index into binary
// data at random (binary PLY vertices, glTF/GLB buffers). Pages are the kernel's page
// cache, not heap: `release()` drops them from this process's resident set (they fault
// back in from the page cache, or the disk, when touched again), which is how the readers
// keep their RSS bounded on files larger than memory.
#pragma once
#include <cstddef>
#include <string>

namespace rayline::scene {

class MappedFile {
 public:
  // Throws InputError(path, "", ...) when the file cannot be opened or mapped. An empty
  // file maps to data() == nullptr, size() == 0.
  explicit MappedFile(const std::string& path);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  const unsigned char* data() const { return data_; }
  std::size_t size() const { return size_; }
  const std::string& path() const { return path_; }

  // Hints that the mapping will be read front to back (read-ahead, early reuse of pages).
  void advise_sequential() const;
  // Drops the pages of [from, to) (rounded inwards to pages; whole file by default)
  // from the resident set. The contents stay valid.
  void release(const unsigned char* from = nullptr, const unsigned char* to = nullptr) const;

 private:
  std::string path_;
  const unsigned char* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace rayline::scene
