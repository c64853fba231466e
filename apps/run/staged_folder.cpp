#include "apps/run/staged_folder.hpp"

#include <filesystem>

#include "common/error.hpp"
#include "common/output_folder.hpp"
#include "common/unfinished_output.hpp"

namespace rayline::cli {

namespace fs = std::filesystem;

StagedFolder::StagedFolder(std::string target, std::string shown, std::string flag, std::function<void()> recheck)
    : target_(std::move(target)), shown_(std::move(shown)), flag_(std::move(flag)), path_(partial_folder(target_)),
      recheck_(std::move(recheck)), guard_(std::make_unique<unfinished::Guard>(path_)) {
  std::error_code ec;
  fs::remove_all(path_, ec);
  fs::create_directories(path_, ec);
  if (ec || !fs::is_directory(path_)) {
    const std::string why = ec ? ec.message() : std::string("not a folder");
    fs::remove_all(path_, ec);
    throw InputError(shown_, flag_, "cannot create the folder: " + why);
  }
}

StagedFolder::~StagedFolder() {
  std::error_code ec;
  if (!published_) fs::remove_all(path_, ec);
}

void StagedFolder::publish() {
  if (recheck_) recheck_();
  publish_folder(path_, target_, flag_);
  published_ = true;
}

}  // namespace rayline::cli
