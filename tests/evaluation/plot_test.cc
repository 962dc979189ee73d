#include "evaluation/plot.h"

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/run_recorder.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

// True when a pixel near `p` has (about) the colour `color`.
bool ColorNear(const cv::Mat& image, cv::Point2d p, const cv::Scalar& color) {
  for (int dy = -2; dy <= 2; ++dy) {
    for (int dx = -2; dx <= 2; ++dx) {
      const int x = static_cast<int>(std::lround(p.x)) + dx,
                y = static_cast<int>(std::lround(p.y)) + dy;
      if (x < 0 || y < 0 || x >= image.cols || y >= image.rows) continue;
      const cv::Vec3b v = image.at<cv::Vec3b>(y, x);
      if (std::abs(v[0] - color[0]) + std::abs(v[1] - color[1]) +
              std::abs(v[2] - color[2]) <
          30)
        return true;
    }
  }
  return false;
}

TEST(PlotTest, SeriesAreDrawnWhereTheFramePutsThem) {
  const std::vector<Series> series = {
      {"psnr", {0, 10, 20, 40}, {15, 20, 24, 26}},
      {"upsnr", {0, 10, 20, 40}, {12, 14, 15, 15.5}}};
  PlotOptions options;
  options.y_label = "PSNR (dB)";
  const cv::Mat image = DrawPlot(series, options);
  EXPECT_EQ(image.cols, 960);
  EXPECT_EQ(image.rows, 600);
  const PlotFrame frame = FitFrame(series, options);
  for (std::size_t s = 0; s < series.size(); ++s) {
    for (std::size_t i = 0; i < series[s].x.size(); ++i) {
      const cv::Point2d p = frame.ToPixel(series[s].x[i], series[s].y[i]);
      EXPECT_TRUE(frame.area.contains(cv::Point(static_cast<int>(p.x),
                                                static_cast<int>(p.y))) ||
                  i == series[s].x.size() - 1);
      EXPECT_TRUE(ColorNear(image, p, SeriesColor(s)))
          << "series " << s << " point " << i;
    }
  }
  // The far corner of the drawing area holds no series colour.
  EXPECT_FALSE(ColorNear(image, frame.ToPixel(40, 12), SeriesColor(0)));
}

TEST(PlotTest, RunLogBecomesAPngAndEmptyDataIsAnError) {
  testing::TempDir dir;
  {
    RunRecorder recorder(dir / "fit.csv", "fit", {"loss", "psnr", "upsnr"});
    for (int i = 0; i < 5; ++i)
      recorder.Record(i * 100, {1.0 / (i + 1), 20.0 + i, 15.0 + 0.5 * i});
  }
  PlotRunLog(dir / "fit.csv", dir / "fit.png", {"psnr", "upsnr"});
  const Image png = ReadImage(dir / "fit.png");
  EXPECT_EQ(png.width(), 960);
  EXPECT_THROW(PlotRunLog(dir / "fit.csv", dir / "x.png", {"mpsnr"}), Error);
  EXPECT_THROW(DrawPlot({{"nan", {std::nan("")}, {1.0}}}, PlotOptions()),
               Error);
}

}  // namespace
}  // namespace pano4d
