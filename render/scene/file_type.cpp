#include "render/scene/file_type.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>

namespace rayline::scene {

std::string not_a_regular_file(const std::string& path, const std::string& what) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    const int err = errno;
    struct stat link {};
    if (err == ELOOP) return "is a symbolic link loop, not a " + what;
    if (err == ENOENT && ::lstat(path.c_str(), &link) == 0 && S_ISLNK(link.st_mode))
      return "is a symbolic link to a missing file, not a " + what;
    if (err == ENOENT) return what + " does not exist";
    return "cannot reach the " + what + ": " + std::strerror(err);
  }
  if (S_ISREG(st.st_mode)) return "";
  if (S_ISDIR(st.st_mode)) return "is a folder, not a " + what + " (give the file's path)";
  if (S_ISFIFO(st.st_mode)) return "is a FIFO (named pipe), not a " + what;
  if (S_ISSOCK(st.st_mode)) return "is a socket, not a " + what;
  if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)) return "is a device, not a " + what;
  return "is not a regular file, not a " + what;
}

}  // namespace rayline::scene
