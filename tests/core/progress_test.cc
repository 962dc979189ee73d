#include "src/core/progress.h"

#include <cmath>
#include <sstream>

#include <gtest/gtest.h>

#include "src/core/log.h"

namespace pano4d {
namespace {

int CountLines(const std::string& text) {
  return static_cast<int>(std::count(text.begin(), text.end(), '\n'));
}

TEST(ProgressTest, LineShowsBarCountRateAndEta) {
  EXPECT_EQ(
      ProgressBar::FormatLine("fit", 500, 1000, 10.0, "loss 0.0123", false),
      "fit [##########..........]  50%  500/1000  50.0 it/s  ETA 00:10  loss "
      "0.0123");
  EXPECT_EQ(ProgressBar::FormatLine("fit", 1000, 1000, 125.0, "", true),
            "fit [####################] 100%  1000/1000  8.0 it/s  in 02:05");
  EXPECT_EQ(ProgressBar::FormatLine("frames", 30, 0, 2.0, "", false),
            "frames  30 it  15.0 it/s  elapsed 00:02");
  EXPECT_EQ(ProgressBar::FormatLine("sfm", 1, 10, 4.0, "", false),
            "sfm [##..................]  10%  1/10  4.0 s/it  ETA 00:36");
}

TEST(ProgressTest, Durations) {
  EXPECT_EQ(ProgressBar::FormatDuration(0), "00:00");
  EXPECT_EQ(ProgressBar::FormatDuration(65.4), "01:05");
  EXPECT_EQ(ProgressBar::FormatDuration(3723), "1:02:03");
  EXPECT_EQ(ProgressBar::FormatDuration(-1), "--:--");
  EXPECT_EQ(ProgressBar::FormatDuration(std::nan("")), "--:--");
}

TEST(ProgressTest, PlainModeWritesWholeLinesAtEachTenth) {
  std::ostringstream out;
  {
    ProgressBar bar("fit", 100, out);  // a string stream is not a terminal
    EXPECT_EQ(bar.mode(), ProgressBar::Mode::kPlain);
    for (int i = 0; i < 100; ++i) bar.Add();
  }
  const std::string text = out.str();
  EXPECT_EQ(text.find('\r'), std::string::npos);
  EXPECT_EQ(CountLines(text), 11);  // 10%, 20%, ..., 100%, and the final line
  EXPECT_NE(text.find(" 10%  10/100"), std::string::npos);
  EXPECT_NE(text.find("100%  100/100"), std::string::npos);
  EXPECT_NE(text.find(" in 00:00"), std::string::npos);
}

TEST(ProgressTest, LiveModeRedrawsInPlaceAndLogClearsTheLine) {
  std::ostringstream out;
  SetLogSink(&out);
  {
    ProgressBar bar("fit", 10, out, ProgressBar::Mode::kLive);
    bar.Add(5);
    Log(LogLevel::kInfo, "halfway");
    bar.Finish();
    bar.Add(1);  // ignored after Finish
    EXPECT_EQ(bar.done(), 5);
  }
  SetLogSink(nullptr);
  const std::string text = out.str();
  EXPECT_EQ(text.rfind("\r\033[Kfit [", 0), 0u);
  EXPECT_NE(text.find("\r\033[KI "),
            std::string::npos);  // the bar line is erased first
  EXPECT_EQ(text.back(), '\n');
  EXPECT_EQ(CountLines(text), 2);  // the log line and the final bar line
}

TEST(ProgressTest, NoFinalLineWhenAnErrorUnwinds) {
  std::ostringstream out;
  try {
    ProgressBar bar("fit", 100, out);
    bar.Add(50);
    throw std::runtime_error("disk full");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(out.str().find(" in 00:"), std::string::npos) << out.str();
  EXPECT_NE(out.str().find(" 50%"), std::string::npos);
}

// A bar that shows only past a delay: a loop quicker than that prints
// nothing in either mode; the same loop without the delay does.
TEST(ProgressTest, AQuickLoopUnderItsDelayIsSilent) {
  for (const ProgressBar::Mode mode :
       {ProgressBar::Mode::kPlain, ProgressBar::Mode::kLive}) {
    std::ostringstream quiet, shown;
    {
      ProgressBar bar("step", 10, quiet, mode, /*show_after_s=*/3600);
      for (int i = 0; i < 10; ++i) bar.Add();
    }
    {
      ProgressBar bar("step", 10, shown, mode);
      for (int i = 0; i < 10; ++i) bar.Add();
    }
    EXPECT_TRUE(quiet.str().empty()) << quiet.str();
    EXPECT_NE(shown.str().find("100%  10/10"), std::string::npos);
  }
}

TEST(ProgressTest, OffModeIsSilent) {
  std::ostringstream out;
  {
    ProgressBar bar("x", 3, out, ProgressBar::Mode::kOff);
    bar.Add(3);
  }
  EXPECT_TRUE(out.str().empty());
}

}  // namespace
}  // namespace pano4d
