// InputError: bad user input (platform, job set, scene, profile, CLI). The CLI turns it
// into "FILE: FIELD: message" and exit code 2 (docs/architecture.md, "Bad input").
#pragma once
#include <stdexcept>
#include <string>

namespace rayline {

class InputError : public std::runtime_error {
 public:
  InputError(std::string file, std::string field, const std::string& message)
      : std::runtime_error(format(file, field, message)), file_(std::move(file)), field_(std::move(field)) {}
  const std::string& file() const { return file_; }
  const std::string& field() const { return field_; }

 private:
  static std::string format(const std::string& file, const std::string& field, const std::string& msg) {
    std::string s = file.empty() ? std::string("<input>") : file;
    if (!field.empty()) s += ": " + field;
    return s + ": " + msg;
  }
  std::string file_, field_;
};

}  // namespace rayline
