// The output files of one run that appear together or not at all (`render`: the image, its
// PNG preview, metrics, timeline and jobs CSV, and any recordings). Each is written into a
// staging folder beside it, TARGET.partial.<pid>@<host>/ (one per output folder, registered
// for removal on interrupt, common/unfinished_output.hpp), and renamed into place only once
// every one was written. A write that fails (a full disk, a file size limit) is a failed
// run, not bad input: it throws OutputWriteError naming the file, and nothing is renamed.
#pragma once
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace rayline::unfinished {
class Guard;
}

namespace rayline::cli {

// "cannot write FILE: reason" (exit 1 through guarded()).
class OutputWriteError : public std::runtime_error {
 public:
  OutputWriteError(const std::string& file, const std::string& reason)
      : std::runtime_error("cannot write " + file + ": " + reason) {}
};

// Writes `content` to a new file at `path` (created or truncated) and flushes it to the
// disk before returning, so a later rename cannot put an empty file where a good one was
// and a delayed write error (a full disk) shows here. Throws std::runtime_error with the
// system's reason.
void write_whole_file(const std::string& path, const std::string& content);

class OutputSet {
 public:
  OutputSet();
  ~OutputSet();  // removes the staging folders: whatever was not published
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  // Writes `target` through `write(staged path)`. Whatever `write` throws becomes
  // OutputWriteError(target, its message).
  void write(const std::string& target, const std::function<void(const std::string& staged)>& write);
  // Writes `content` as `target` (flushed to disk before publish).
  void write_text(const std::string& target, const std::string& content);
  // Renames every written file into place, in the order written.
  void publish();

 private:
  struct Stage;
  std::string staged_path(const std::string& target);
  std::vector<std::unique_ptr<Stage>> stages_;
  std::vector<std::pair<std::string, std::string>> files_;  // (staged, target)
};

}  // namespace rayline::cli
