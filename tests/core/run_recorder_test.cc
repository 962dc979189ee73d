#include "src/core/run_recorder.h"

#include <cmath>
#include <sstream>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/log.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

TEST(RunRecorderTest, RowsReadBackWithEmptyCellsForMissingValues) {
  testing::TempDir dir;
  const auto csv = dir / "logs" / "fit.csv";
  {
    RunRecorder recorder(csv, "fit", {"loss", "psnr"});
    recorder.Record(0, {0.5, std::nullopt});
    recorder.Record(100, {0.25, 21.5});
  }
  const RunLog log = ReadRunLog(csv);
  EXPECT_EQ(log.columns,
            (std::vector<std::string>{"wall_s", "cpu_s", "loss", "psnr"}));
  ASSERT_EQ(log.rows.size(), 2u);
  EXPECT_EQ(log.stages[1], "fit");
  EXPECT_EQ(log.iterations[1], 100);
  EXPECT_EQ(log.rows[0][2], 0.5);
  EXPECT_FALSE(log.rows[0][3].has_value());
  EXPECT_EQ(log.rows[1][3], 21.5);
  EXPECT_LE(*log.rows[0][0], *log.rows[1][0]);  // wall time does not go back
}

TEST(RunRecorderTest, NonFiniteValuesAreLoggedNotWrittenAsNumbers) {
  testing::TempDir dir;
  std::ostringstream sink;
  SetLogSink(&sink);
  {
    RunRecorder recorder(dir / "fit.csv", "fit", {"loss"});
    recorder.Record(7, {std::nan("")});
  }
  SetLogSink(nullptr);
  EXPECT_NE(sink.str().find("fit: loss is nan at iteration 7"),
            std::string::npos)
      << sink.str();
  EXPECT_FALSE(ReadRunLog(dir / "fit.csv").rows[0][2].has_value());
}

TEST(RunRecorderTest, ResumeContinuesTheTimeline) {
  testing::TempDir dir;
  const auto csv = dir / "fit.csv";
  {
    RunRecorder recorder(csv, "fit", {"loss"});
    recorder.Record(0, {1.0});
    recorder.Record(10, {0.5});
  }
  const double last = *ReadRunLog(csv).rows.back()[0];
  {
    RunRecorder resumed(csv, "fit", {"loss"}, /*resume=*/true);
    EXPECT_GE(resumed.WallSeconds(), last);
    resumed.Record(20, {0.25});
  }
  const RunLog log = ReadRunLog(csv);
  ASSERT_EQ(log.rows.size(), 3u);  // one header, three rows
  EXPECT_GE(*log.rows[2][0], last);
  EXPECT_THROW(RunRecorder(csv, "fit", {"other"}, true), Error);
}

TEST(RunRecorderTest, BadUseAndBadFilesAreErrors) {
  testing::TempDir dir;
  RunRecorder recorder(dir / "a.csv", "fit", {"loss"});
  EXPECT_THROW(recorder.Record(0, {1.0, 2.0}), Error);
  EXPECT_THROW(RunRecorder(dir / "b.csv", "fit", {"a,b"}), Error);
  WriteFileAtomically(dir / "c.csv", "time,loss\n1,2\n");
  EXPECT_THROW(ReadRunLog(dir / "c.csv"), Error);
  WriteFileAtomically(dir / "d.csv",
                      "stage,iteration,wall_s,cpu_s,loss\nfit,1,0.5,0.5,abc\n");
  try {
    ReadRunLog(dir / "d.csv");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), (dir / "d.csv").string() + " line 2");
    EXPECT_EQ(e.field(), "loss");
  }
}

}  // namespace
}  // namespace pano4d
