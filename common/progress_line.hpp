// Progress of a long run on stderr ("progress on long runs"). On a terminal: one line,
// rewritten in place at most every 0.25 s. In a log file or a pipe, where a rewritten line
// is a flood of carriage returns: whole lines, the first after 10 s and then one every
// 10 s, so a short run prints nothing and a batch job's log shows that it is alive.
#pragma once
#include <chrono>

namespace rayline {

class ProgressLine {
 public:
  enum class Mode { Off, Terminal, Log };
  // Off when quiet, Terminal when stderr is a terminal, else Log.
  static Mode for_stderr(bool quiet);

  explicit ProgressLine(Mode mode, std::chrono::milliseconds terminal_period = std::chrono::milliseconds(250),
                        std::chrono::milliseconds log_period = std::chrono::milliseconds(10000));
  Mode mode() const { return mode_; }
  // Whether a line is due now; a true answer starts the next period, so print it then.
  bool due();
  // One progress line (no newline in `fmt`), prefixed by "[what] " in a log.
  void print(const char* what, const char* fmt, ...) __attribute__((format(printf, 3, 4)));
  // Ends the terminal line, if one was printed (before the run's own output).
  void done();

 private:
  using Clock = std::chrono::steady_clock;
  Mode mode_;
  std::chrono::milliseconds period_;
  Clock::time_point last_;
  bool open_line_ = false;
};

}  // namespace rayline
