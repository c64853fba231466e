#include "apps/cli_common.hpp"

#include <fcntl.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <unistd.h>

#include "apps/run/output_set.hpp"
#include "common/error.hpp"
#include "common/output_folder.hpp"
#include "common/unfinished_output.hpp"

namespace rayline::cli {

int guarded(const std::function<int()>& body) {
  try {
    return body();
  } catch (const InputError& e) {
    std::cerr << "rayline: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "rayline: error: " << e.what() << "\n";
    return kExitFailure;
  }
}

void ensure_parent_dir(const std::string& path, const std::string& flag) {
  namespace fs = std::filesystem;
  if (path.empty()) throw InputError(path, flag, "missing output path");
  const fs::path parent = fs::absolute(fs::path(path)).parent_path();
  std::error_code ec;
  if (fs::is_directory(parent, ec)) return;
  fs::create_directories(parent, ec);
  if (ec || !fs::is_directory(parent)) throw InputError(path, flag, "cannot create folder " + parent.string() + ": " + ec.message());
}

void ensure_dir(const std::string& dir, const std::string& flag) {
  namespace fs = std::filesystem;
  if (dir.empty()) throw InputError(dir, flag, "missing output folder");
  std::error_code ec;
  if (fs::is_directory(dir, ec)) return;
  fs::create_directories(dir, ec);
  std::error_code ignored;
  if (ec || !fs::is_directory(dir, ignored))
    throw InputError(dir, flag, "cannot create the folder" + (ec ? ": " + ec.message() : std::string()));
}

void check_output_file(const std::string& path, const std::string& flag, const std::string& example) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!path.empty() && fs::is_directory(path, ec))
    throw InputError(path, flag, "is a folder; give a file name such as " + example);
  ensure_parent_dir(path, flag);
  const fs::path probe = fs::absolute(path).parent_path() / (".rayline-probe." + std::to_string(::getpid()));
  std::ofstream f(probe);
  if (!f) throw InputError(path, flag, "output folder is not writable");
  f.close();
  fs::remove(probe, ec);
}

namespace {
bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec;
  if (std::filesystem::exists(a, ec) && std::filesystem::exists(b, ec)) return std::filesystem::equivalent(a, b, ec);
  return normal_path(a) == normal_path(b);
}
}  // namespace

void check_distinct(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs) {
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    if (outputs[i].path.empty()) continue;
    for (std::size_t j = 0; j < i; ++j)
      if (!outputs[j].path.empty() && same_file(outputs[i].path, outputs[j].path))
        throw InputError(outputs[i].path, outputs[i].flag,
                         "is also the file of " + outputs[j].flag + "; give each output its own name");
    for (const NamedPath& in : inputs)
      if (!in.path.empty() && same_file(outputs[i].path, in.path))
        throw InputError(outputs[i].path, outputs[i].flag,
                         "is the input of " + in.flag + "; writing it would destroy that file");
  }
}

void check_not_inside(const std::string& folder, const std::string& folder_flag, const std::vector<NamedPath>& inputs) {
  for (const NamedPath& in : inputs)
    if (!in.path.empty() && folder_holds(folder, in.path))
      throw InputError(in.path, in.flag, "lies inside " + folder_flag + " " + folder +
                                             ", which the run replaces; move it out or choose another " + folder_flag);
}

void write_file_atomic(const std::string& path, const std::string& content) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw InputError(path, "", "is a folder; cannot write the file there");
  ensure_parent_dir(path, "");
  const fs::path target(path);
  const fs::path tmp = unfinished::fresh_temp_name(target.string(), "tmp");
  const unfinished::Guard unfinished_guard(tmp.string());  // removed if the run is interrupted
  const auto fail = [&](const std::string& why) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw OutputWriteError(path, why);
  };
  try {
    write_whole_file(tmp.string(), content);
  } catch (const std::runtime_error& e) {
    fail(e.what());
  }
  fs::rename(tmp, target, ec);
  if (ec) fail("cannot move it into place: " + ec.message());
}

}  // namespace rayline::cli
