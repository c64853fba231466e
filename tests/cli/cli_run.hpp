// Test support: run the rayline binary; capture stdout, stderr (separately, and together
// in `all`) and the exit code.
#pragma once
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace rayline::testing {

struct CliResult {
  int code = -1;
  std::string out;  // stdout
  std::string err;  // stderr
  std::string all;  // stdout then stderr
};

inline CliResult rayline_cli(const std::string& args) {
  namespace fs = std::filesystem;
  static int counter = 0;
  const fs::path err_file = fs::temp_directory_path() /
                            ("rayline-cli-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + ".stderr");
  const std::string cmd = std::string(RAYLINE_BINARY) + " " + args + " 2>" + err_file.string();
  CliResult r;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  std::size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = ::pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(err_file);
  std::stringstream ss;
  ss << in.rdbuf();
  r.err = ss.str();
  r.all = r.out + r.err;
  std::error_code ec;
  fs::remove(err_file, ec);
  return r;
}

}  // namespace rayline::testing
