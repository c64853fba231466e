// A folder of results that several runs fill (`compare`'s OUT/<scheduler>/, a client sweep's
// OUT/clients-N/) appears whole or not at all: the runs write into OUT.partial.<pid>@<host>/
// and the parent swaps it in for OUT only once every run completed (common/output_folder.hpp).
// A run that fails, a parent that is interrupted or killed, publishes nothing under OUT.
#pragma once
#include <functional>
#include <memory>
#include <string>

namespace rayline::unfinished {
class Guard;
}

namespace rayline::cli {

class StagedFolder {
 public:
  // `target`: OUT as replaceable_folder returned it. `recheck` runs again just before the
  // swap (the user may have put a file into OUT meanwhile) and throws InputError to refuse.
  // Creates the staging folder (and OUT's parent); InputError(shown, flag, ...) if it cannot.
  StagedFolder(std::string target, std::string shown, std::string flag, std::function<void()> recheck);
  ~StagedFolder();  // removes the staging folder unless it was published
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;

  // Where the runs write: the staging folder.
  const std::string& path() const { return path_; }
  // Swaps the staging folder in for the target (publish_folder).
  void publish();

 private:
  std::string target_, shown_, flag_, path_;
  std::function<void()> recheck_;
  std::unique_ptr<unfinished::Guard> guard_;  // removed if the run is interrupted
  bool published_ = false;
};

}  // namespace rayline::cli
