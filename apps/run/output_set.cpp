#include "apps/run/output_set.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "common/error.hpp"
#include "common/unfinished_output.hpp"

namespace rayline::cli {

namespace fs = std::filesystem;

struct OutputSet::Stage {
  std::string dir;     // the output folder, as fs::path::parent_path gives it
  std::string folder;  // its staging folder
  unfinished::Guard guard;
  explicit Stage(std::string d, std::string f) : dir(std::move(d)), folder(std::move(f)), guard(folder) {}
};

OutputSet::OutputSet() = default;

OutputSet::~OutputSet() {
  for (const auto& s : stages_) {
    std::error_code ec;
    fs::remove_all(s->folder, ec);
  }
}

std::string OutputSet::staged_path(const std::string& target) {
  const fs::path t = fs::absolute(target);
  unfinished::sweep_stale(t.string());  // what an ended run left under this output's name
  const std::string dir = t.parent_path().string();
  Stage* stage = nullptr;
  for (const auto& s : stages_)
    if (s->dir == dir) stage = s.get();
  if (!stage) {
    stages_.push_back(std::make_unique<Stage>(dir, unfinished::temp_name(t.string(), "partial")));
    stage = stages_.back().get();
    std::error_code ec;
    fs::remove_all(stage->folder, ec);
    if (!fs::create_directory(stage->folder, ec) || ec)
      throw OutputWriteError(target, "cannot create the folder " + stage->folder + ": " +
                                         (ec ? ec.message() : std::string("it exists")));
  }
  return (fs::path(stage->folder) / t.filename()).string();
}

void OutputSet::write(const std::string& target, const std::function<void(const std::string& staged)>& write) {
  const std::string staged = staged_path(target);
  try {
    write(staged);
  } catch (const InputError& e) {
    // The writers name the file they were given (the staged one) and what went wrong.
    std::string why = e.what();
    const std::string prefix = e.file() + ": " + (e.field().empty() ? "" : e.field() + ": ");
    if (why.starts_with(prefix)) why.erase(0, prefix.size());
    throw OutputWriteError(target, why);
  } catch (const std::exception& e) {
    throw OutputWriteError(target, e.what());
  }
  files_.emplace_back(staged, target);
}

void write_whole_file(const std::string& path, const std::string& content) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) throw std::runtime_error(std::strerror(errno));
  for (std::size_t done = 0; done < content.size();) {
    const ssize_t n = ::write(fd, content.data() + done, content.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : EIO;
      ::close(fd);
      throw std::runtime_error(std::strerror(err));
    }
    done += static_cast<std::size_t>(n);
  }
  const int err = ::fsync(fd) != 0 ? errno : 0;
  if (::close(fd) != 0 || err != 0) throw std::runtime_error(std::strerror(err ? err : errno));
}

void OutputSet::write_text(const std::string& target, const std::string& content) {
  write(target, [&](const std::string& staged) { write_whole_file(staged, content); });
}

void OutputSet::publish() {
  for (const auto& [staged, target] : files_) {
    std::error_code ec;
    fs::rename(staged, target, ec);
    if (ec) throw OutputWriteError(target, "cannot move it into place: " + ec.message());
  }
  files_.clear();
}

}  // namespace rayline::cli
