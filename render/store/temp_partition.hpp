// A temporary partition folder, /tmp/rayline-blocks-<ns>.partial.<pid>@<host>, for a render
// (or a calibration's renders) given no --blocks-dir. Registered as unfinished output, so an
// interrupted run removes it too; what killed runs left under that prefix on this host is
// swept first (common/unfinished_output.hpp). Removed when the object goes.
#pragma once
#include <string>

namespace rayline::engine {

class TempPartition {
 public:
  TempPartition();
  ~TempPartition();
  TempPartition(const TempPartition&) = delete;
  TempPartition& operator=(const TempPartition&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace rayline::engine
