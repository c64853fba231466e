#include "common/output_folder.hpp"

#include <fcntl.h>  // AT_FDCWD
#include <stdio.h>  // renameat2, RENAME_EXCHANGE, RENAME_NOREPLACE (glibc >= 2.28)

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "common/error.hpp"
#include "common/unfinished_output.hpp"

namespace rayline {
namespace fs = std::filesystem;

namespace {

bool matches(std::string_view name, std::string_view pattern) {
  const std::size_t star = pattern.find('*');
  if (star == std::string_view::npos) return name == pattern;
  const std::string_view head = pattern.substr(0, star), tail = pattern.substr(star + 1);
  return name.size() >= head.size() + tail.size() && name.substr(0, head.size()) == head &&
         name.substr(name.size() - tail.size()) == tail;
}

}  // namespace

std::string normal_path(const std::string& path) {
  std::error_code ec;
  fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec);
  if (ec) p = fs::absolute(path, ec);  // unresolvable (a folder we may not enter): as written
  p = p.lexically_normal();
  if (p.has_relative_path() && p.filename().empty()) p = p.parent_path();
  return p.string();
}

bool folder_holds(const std::string& folder, const std::string& path) {
  const fs::path a = normal_path(folder), b = normal_path(path);
  auto ia = a.begin(), ib = b.begin();
  for (; ia != a.end(); ++ia, ++ib)
    if (ib == b.end() || *ia != *ib) return false;
  return true;
}

std::string replaceable_folder(const std::string& path, const std::string& flag, const OwnFiles& own) {
  return replaceable_folder(path, flag, own, {}, {});
}

std::string replaceable_folder(const std::string& path, const std::string& flag, const OwnFiles& own,
                               const OwnFiles& own_folders, const std::function<void(const std::string&)>& check_folder) {
  if (path.empty()) throw InputError(path, flag, "missing output folder");
  std::error_code ec;
  const fs::path target = normal_path(path);
  const fs::path cwd = fs::current_path(ec);
  if (!target.has_relative_path() || (!ec && folder_holds(target.string(), cwd.string())))
    throw InputError(path, flag, "is the current folder or holds it; results replace the whole folder, so give a "
                                 "folder of their own (e.g. out/run1)");
  const fs::file_status st = fs::status(target, ec);
  if (!fs::exists(st)) return target.string();
  if (!fs::is_directory(st)) throw InputError(path, flag, "exists and is not a folder; not replacing it");
  const auto any_match = [](const std::string& name, const OwnFiles& patterns) {
    for (std::string_view p : patterns)
      if (matches(name, p)) return true;
    return false;
  };
  for (fs::directory_iterator it(target, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    std::error_code e;
    const bool link = it->is_symlink(e);
    if (!link && it->is_regular_file(e) && any_match(name, own)) continue;
    if (!link && check_folder && it->is_directory(e) && any_match(name, own_folders)) {
      check_folder(it->path().string());
      continue;
    }
    throw InputError(path, flag, "folder holds '" + name + "', which this command does not write; not replacing it "
                                 "(give a new folder, or remove it yourself)");
  }
  if (ec) throw InputError(path, flag, "cannot list the folder: " + ec.message());
  return target.string();
}

std::string partial_folder(const std::string& target) {
  return unfinished::fresh_temp_name(target, "partial");
}

void publish_folder(const std::string& partial, const std::string& target, const std::string& flag) {
  std::error_code ec;
  // Linux: move into an absent place without replacing (RENAME_NOREPLACE), or swap the two
  // folders in one step (RENAME_EXCHANGE), so that runs publishing into one folder at once
  // leave the last one's results and nothing else: no moment without a target, nothing set
  // aside to be lost. (Other file systems, e.g. some network ones: the two-rename path below.)
  int err = 0;
  for (int attempt = 0; attempt < 16; ++attempt) {
    if (::renameat2(AT_FDCWD, partial.c_str(), AT_FDCWD, target.c_str(), RENAME_NOREPLACE) == 0) return;
    err = errno;
    if (err != EEXIST) break;
    if (::renameat2(AT_FDCWD, partial.c_str(), AT_FDCWD, target.c_str(), RENAME_EXCHANGE) == 0) {
      // `partial` now names what was the target: a folder replaceable_folder let go. (Should
      // a file have taken its place since, it is swapped back, not removed.)
      if (!fs::is_directory(fs::symlink_status(partial, ec))) {
        ::renameat2(AT_FDCWD, partial.c_str(), AT_FDCWD, target.c_str(), RENAME_EXCHANGE);
        throw InputError(target, flag, "became something other than a folder while the run wrote; not replacing it");
      }
      fs::remove_all(partial, ec);
      return;
    }
    err = errno;
    if (err != ENOENT || !fs::exists(fs::symlink_status(partial, ec))) break;  // (ENOENT: the target just went)
  }
  if (err != EINVAL && err != ENOSYS && err != EOPNOTSUPP)
    throw InputError(target, flag, "cannot move the results into place: " + std::string(std::strerror(err)));
  if (!fs::exists(fs::symlink_status(target, ec))) {
    fs::rename(partial, target, ec);
    if (ec) throw InputError(target, flag, "cannot move the results into place: " + ec.message());
    return;
  }
  const std::string old = unfinished::temp_name(target, "old");
  fs::rename(target, old, ec);
  if (ec) throw InputError(target, flag, "cannot move the earlier results aside: " + ec.message());
  fs::rename(partial, target, ec);
  if (ec) {
    std::error_code back;
    fs::rename(old, target, back);
    throw InputError(target, flag, "cannot move the results into place: " + ec.message());
  }
  fs::remove_all(old, ec);
}

}  // namespace rayline
