// Test support: run the rayline binary, capture stdout+stderr and the exit code.
#pragma once
#include <array>
#include <cstdio>
#include <string>
#include <sys/wait.h>

namespace rayline::testing {

struct CliResult {
  int code = -1;
  std::string out;  // stdout and stderr together
};

inline CliResult rayline_cli(const std::string& args) {
  CliResult r;
  const std::string cmd = std::string(RAYLINE_BINARY) + " " + args + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  std::size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = ::pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace rayline::testing
