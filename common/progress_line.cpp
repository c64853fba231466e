#include "common/progress_line.hpp"

#include <unistd.h>

#include <cstdarg>
#include <cstdio>

namespace rayline {

ProgressLine::Mode ProgressLine::for_stderr(bool quiet) {
  if (quiet) return Mode::Off;
  return ::isatty(2) ? Mode::Terminal : Mode::Log;
}

ProgressLine::ProgressLine(Mode mode, std::chrono::milliseconds terminal_period, std::chrono::milliseconds log_period)
    : mode_(mode), period_(mode == Mode::Terminal ? terminal_period : log_period), last_(Clock::now()) {}

bool ProgressLine::due() {
  if (mode_ == Mode::Off) return false;
  const auto now = Clock::now();
  if (now - last_ < period_) return false;
  last_ = now;
  return true;
}

void ProgressLine::print(const char* what, const char* fmt, ...) {
  if (mode_ == Mode::Off) return;
  char line[256];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(line, sizeof line, fmt, args);
  va_end(args);
  if (mode_ == Mode::Terminal) {
    std::fprintf(stderr, "\r%-70s", line);  // (padded: a shorter line hides a longer one)
    open_line_ = true;
  } else {
    std::fprintf(stderr, "[%s] %s\n", what, line);
  }
  std::fflush(stderr);
}

void ProgressLine::done() {
  if (!open_line_) return;
  std::fprintf(stderr, "\n");
  open_line_ = false;
}

}  // namespace rayline
