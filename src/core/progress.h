#pragma once

#include <chrono>
#include <cstdint>
#include <iostream>
#include <string>

namespace pano4d {

// A progress bar for long loops, in the manner of tqdm:
//   fit [##########..........]  50%  500/1000  41.2 it/s  ETA 00:12  loss
//   0.0123
// On a terminal the line is redrawn in place (at most every 0.1 s); when the
// stream is not a terminal (a log file, CI) it prints plain lines instead, at
// every 10% and at least every 10 s, so logs stay readable. Writes to
// std::cerr by default so that stdout stays clean for results (JSON, tables).
class ProgressBar {
 public:
  enum class Mode { kAuto, kLive, kPlain, kOff };

  // total <= 0: unknown length (counts and rate, no bar or ETA).
  // show_after_s > 0: nothing is shown unless the loop is still running
  // that long after the bar was made (a step inside a longer loop that is
  // usually quick, such as one expansion step, stays silent then).
  ProgressBar(std::string label, std::int64_t total,
              std::ostream& out = std::cerr, Mode mode = Mode::kAuto,
              double show_after_s = 0);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  void Add(std::int64_t steps = 1);
  // Free text shown at the end of the line, e.g. the current loss.
  void SetStatus(std::string status);
  // Prints the final line (elapsed time, mean rate); later calls do nothing.
  // The destructor calls it, except while an exception unwinds.
  void Finish();

  std::int64_t done() const { return done_; }
  Mode mode() const { return mode_; }

  // The line for a state; pure, for tests and custom displays.
  static std::string FormatLine(const std::string& label, std::int64_t done,
                                std::int64_t total, double elapsed_s,
                                const std::string& status, bool finished);
  // "07:05", or "1:02:03" past an hour; "--:--" when not finite or negative.
  static std::string FormatDuration(double seconds);

 private:
  void Draw(bool finished);
  double ElapsedSeconds() const;

  std::string label_;
  std::int64_t total_;
  std::ostream& out_;
  Mode mode_;
  double show_after_s_;
  std::string status_;
  std::int64_t done_ = 0;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_;
  double last_draw_s_ = -1.0;
  int last_plain_decile_ = 0;
};

}  // namespace pano4d
