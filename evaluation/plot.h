#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace pano4d {

// Line plots drawn with OpenCV (no Python at run time): white background,
// axes with ticks, labels with units, a legend, one colour per series.

struct Series {
  std::string label;
  std::vector<double> x;
  std::vector<double> y;
};

// A vertical line across the plot at x, labelled (a fit's convergence).
struct PlotMarker {
  double x = 0;
  std::string label;
};

struct PlotOptions {
  std::string title;
  std::vector<PlotMarker> markers;
  std::string x_label = "wall time (s)";
  std::string y_label;
  int width = 960;
  int height = 600;
};

// The data-to-pixel mapping a plot uses (also what tests check against).
struct PlotFrame {
  cv::Rect area;  // the drawing area inside the axes, in pixels
  double x_min = 0, x_max = 1, y_min = 0, y_max = 1;
  cv::Point2d ToPixel(double x, double y) const;
};

// A frame that fits all finite points of `series`, with a margin.
PlotFrame FitFrame(const std::vector<Series>& series,
                   const PlotOptions& options);

// Draws the series (BGR, 8-bit): a line through each series' finite points
// (missing ones are skipped, not drawn as gaps) and a dot on each. Throws
// pano4d::Error when no series has a finite point.
cv::Mat DrawPlot(const std::vector<Series>& series, const PlotOptions& options);

// Plots columns of a RunRecorder CSV against wall time into a PNG (written
// atomically). `columns` empty: every value column but wall_s and cpu_s.
// `marks`: (iteration, label) pairs drawn as PlotMarkers at the wall time
// of the log's row of that iteration (none where the log has no such row).
void PlotRunLog(
    const std::filesystem::path& csv, const std::filesystem::path& png,
    std::vector<std::string> columns = {}, const std::string& title = "",
    const std::vector<std::pair<std::int64_t, std::string>>& marks = {});

// The colour of series i (BGR).
cv::Scalar SeriesColor(std::size_t i);

}  // namespace pano4d
