// Test support: run the rayline binary; capture stdout, stderr (separately, and together
// in `all`) and the exit code.
#pragma once
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <vector>

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

// rayline ARGS... with a resource limit set in its process (setrlimit before exec), e.g.
// RLIMIT_FSIZE for a disk that fills up, RLIMIT_AS for a machine out of address space. Every
// signal is at its default, as from a terminal. code is -1 when a signal ended it.
inline CliResult rayline_limited(int resource, rlim_t limit, const std::vector<std::string>& args) {
  namespace fs = std::filesystem;
  static int counter = 0;
  const std::string stem = (fs::temp_directory_path() / ("rayline-limited-" + std::to_string(::getpid()) + "-" +
                                                         std::to_string(counter++))).string();
  const std::string out_file = stem + ".stdout", err_file = stem + ".stderr";
  CliResult r;
  const pid_t pid = ::fork();
  if (pid < 0) return r;
  if (pid == 0) {
    for (int sig : {SIGXFSZ, SIGINT, SIGTERM, SIGHUP}) std::signal(sig, SIG_DFL);
    if (!std::freopen(out_file.c_str(), "w", stdout) || !std::freopen(err_file.c_str(), "w", stderr)) ::_exit(99);
    const rlimit lim{limit, limit};
    if (::setrlimit(resource, &lim) != 0) ::_exit(97);
    std::vector<char*> argv{const_cast<char*>(RAYLINE_BINARY)};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(RAYLINE_BINARY, argv.data());
    ::_exit(98);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  const auto slurp = [](const std::string& p) {
    std::ifstream in(p);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  };
  r.out = slurp(out_file);
  r.err = slurp(err_file);
  r.all = r.out + r.err;
  std::error_code ec;
  fs::remove(out_file, ec);
  fs::remove(err_file, ec);
  return r;
}

}  // namespace rayline::testing
