#include "src/core/log.h"

#include <regex>
#include <sstream>

#include <gtest/gtest.h>

namespace pano4d {
namespace {

class LogTest : public ::testing::Test {
 protected:
  void SetUp() override { SetLogSink(&sink_); }
  void TearDown() override {
    SetLogSink(nullptr);
    SetLogLevel(LogLevel::kInfo);
  }
  std::ostringstream sink_;
};

TEST_F(LogTest, LineFormat) {
  PANO4D_LOG(kInfo) << "registered " << 42 << " frames";
  EXPECT_TRUE(std::regex_match(
      sink_.str(),
      std::regex(R"(I \d\d:\d\d:\d\d\.\d\d\d registered 42 frames\n)")))
      << sink_.str();
}

TEST_F(LogTest, LevelFiltersAndSkipsFormatting) {
  SetLogLevel(LogLevel::kWarning);
  int evaluated = 0;
  auto count = [&] { return ++evaluated; };
  PANO4D_LOG(kInfo) << "hidden " << count();
  PANO4D_LOG(kWarning) << "shown " << count();
  EXPECT_EQ(evaluated, 1);
  EXPECT_EQ(sink_.str().find("hidden"), std::string::npos);
  EXPECT_EQ(sink_.str().rfind("W ", 0), 0u);
}

TEST_F(LogTest, ParseLevelNames) {
  EXPECT_EQ(ParseLogLevel("debug"), LogLevel::kDebug);
  EXPECT_EQ(ParseLogLevel("warn"), LogLevel::kWarning);
  EXPECT_EQ(ParseLogLevel("error"), LogLevel::kError);
  EXPECT_FALSE(ParseLogLevel("loud").has_value());
}

}  // namespace
}  // namespace pano4d
