#include "src/core/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <sstream>

#include "src/core/log.h"

namespace pano4d {
namespace {

constexpr int kBarWidth = 20;
constexpr double kLiveRedrawSeconds = 0.1;  // smooth enough, cheap enough
constexpr double kPlainIntervalSeconds = 10.0;

bool IsTerminal(const std::ostream& out) {
  if (&out == &std::cerr || &out == &std::clog)
    return ::isatty(STDERR_FILENO) == 1;
  if (&out == &std::cout) return ::isatty(STDOUT_FILENO) == 1;
  return false;
}

std::string FormatRate(double per_second) {
  char buffer[32];
  if (per_second >= 100) {
    std::snprintf(buffer, sizeof(buffer), "%.0f it/s", per_second);
  } else if (per_second >= 1 || per_second == 0) {
    std::snprintf(buffer, sizeof(buffer), "%.1f it/s", per_second);
  } else {
    std::snprintf(buffer, sizeof(buffer), "%.1f s/it", 1.0 / per_second);
  }
  return buffer;
}

}  // namespace

ProgressBar::ProgressBar(std::string label, std::int64_t total,
                         std::ostream& out, Mode mode, double show_after_s)
    : label_(std::move(label)),
      total_(total),
      out_(out),
      mode_(mode == Mode::kAuto ? (IsTerminal(out) ? Mode::kLive : Mode::kPlain)
                                : mode),
      show_after_s_(show_after_s),
      start_(std::chrono::steady_clock::now()) {
  if (mode_ == Mode::kLive) Draw(false);
}

ProgressBar::~ProgressBar() {
  // Unwinding from an error: a final "done" line would mislead, and the
  // error message follows anyway.
  if (std::uncaught_exceptions() > 0) {
    finished_ = true;
    if (mode_ == Mode::kLive && last_draw_s_ >= 0)
      internal::WriteConsole(out_, "\n", false);
    return;
  }
  Finish();
}

double ProgressBar::ElapsedSeconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                       start_)
      .count();
}

void ProgressBar::Add(std::int64_t steps) {
  if (finished_) return;
  done_ += steps;
  if (mode_ == Mode::kOff) return;
  const double now = ElapsedSeconds();
  if (mode_ == Mode::kLive) {
    if (now - last_draw_s_ >= kLiveRedrawSeconds) Draw(false);
    return;
  }
  const int decile =
      total_ > 0
          ? static_cast<int>(std::min<std::int64_t>(done_ * 10 / total_, 10))
          : 0;
  if (decile > last_plain_decile_ ||
      now - std::max(last_draw_s_, 0.0) >= kPlainIntervalSeconds) {
    last_plain_decile_ = std::max(decile, last_plain_decile_);
    Draw(false);
  }
}

void ProgressBar::SetStatus(std::string status) { status_ = std::move(status); }

void ProgressBar::Finish() {
  if (finished_) return;
  finished_ = true;
  if (mode_ != Mode::kOff) Draw(true);
}

void ProgressBar::Draw(bool finished) {
  const double now = ElapsedSeconds();
  if (last_draw_s_ < 0 && now < show_after_s_) return;  // quick: silent
  last_draw_s_ = now;
  const std::string line =
      FormatLine(label_, done_, total_, last_draw_s_, status_, finished);
  if (mode_ == Mode::kLive) {
    internal::WriteConsole(out_, "\r\033[K" + line + (finished ? "\n" : ""),
                           !finished);
  } else {
    internal::WriteConsole(out_, line + "\n", false);
  }
}

std::string ProgressBar::FormatDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--:--";
  const auto total = static_cast<long long>(std::llround(seconds));
  char buffer[32];
  if (total >= 3600) {
    std::snprintf(buffer, sizeof(buffer), "%lld:%02lld:%02lld", total / 3600,
                  total / 60 % 60, total % 60);
  } else {
    std::snprintf(buffer, sizeof(buffer), "%02lld:%02lld", total / 60,
                  total % 60);
  }
  return buffer;
}

std::string ProgressBar::FormatLine(const std::string& label, std::int64_t done,
                                    std::int64_t total, double elapsed_s,
                                    const std::string& status, bool finished) {
  std::ostringstream out;
  out << label;
  const double rate = elapsed_s > 0 ? done / elapsed_s : 0.0;
  if (total > 0) {
    const double fraction =
        std::clamp(static_cast<double>(done) / total, 0.0, 1.0);
    const int filled = static_cast<int>(fraction * kBarWidth);
    out << " [" << std::string(filled, '#')
        << std::string(kBarWidth - filled, '.') << "] ";
    char percent[8];
    std::snprintf(percent, sizeof(percent), "%3d%%",
                  static_cast<int>(fraction * 100));
    out << percent << "  " << done << "/" << total;
  } else {
    out << "  " << done << " it";
  }
  out << "  " << FormatRate(rate);
  if (finished) {
    out << "  in " << FormatDuration(elapsed_s);
  } else if (total > 0) {
    const double eta = rate > 0 ? (total - done) / rate : -1.0;
    out << "  ETA " << FormatDuration(eta);
  } else {
    out << "  elapsed " << FormatDuration(elapsed_s);
  }
  if (!status.empty()) out << "  " << status;
  return out.str();
}

}  // namespace pano4d
