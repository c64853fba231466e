// ReplayLog::save on a disk that fills up: the error must reach the caller even when the
// whole log sits in the stream's buffer until the file is closed (a full disk shows only
// on that last write). The disk is made "full" with RLIMIT_FSIZE in a child process.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "workload/path_trace_model.hpp"

namespace {

using namespace rayline;

TEST(ReplayLogSave, AFullDiskOnTheLastWriteIsReported) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("rayline-replay-" + std::to_string(::getpid()) + ".log")).string();
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ReplayLog log;
    for (int b = 0; b < 20; ++b) {
      SplitContext ctx;
      ctx.block = b;
      log.append(ctx, 100, {60, 40});  // ≈ 40 bytes a line: ≈ 900 bytes, one buffer
    }
    std::signal(SIGXFSZ, SIG_IGN);  // a write past the limit fails with EFBIG instead
    const rlimit limit{256, 256};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    try {
      log.save(path, "");
    } catch (const std::runtime_error&) {
      ::_exit(0);  // reported
    }
    ::_exit(3);  // silently truncated
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  std::remove(path.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "save() returned normally on a file it could not write whole";
}

}  // namespace
