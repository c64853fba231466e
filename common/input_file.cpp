#include "common/input_file.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "common/error.hpp"

namespace rayline {

std::ifstream open_input(const std::string& path, const std::string& what) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path, "", "is a folder, not a " + what + " (give the file's path)");
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const int e = errno;
    throw InputError(path, "", "cannot open " + what + (e != 0 ? std::string(": ") + std::strerror(e) : std::string()));
  }
  return in;
}

}  // namespace rayline
