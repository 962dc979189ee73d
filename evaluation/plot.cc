#include "evaluation/plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/run_recorder.h"

namespace pano4d {
namespace {

constexpr int kMarginLeft = 80;
constexpr int kMarginRight = 210;  // room for the legend
constexpr int kMarginTop = 56;
constexpr int kMarginBottom = 64;
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr double kFontScale = 0.5;
const cv::Scalar kBlack(0, 0, 0), kGrid(225, 225, 225), kWhite(255, 255, 255);

// A tick step of 1, 2 or 5 times a power of ten giving about `target` ticks.
double NiceStep(double range, int target) {
  const double raw = range / target;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * power >= raw) return m * power;
  }
  return 10 * power;
}

std::string TickText(double v, double step) {
  char buffer[32];
  const int decimals =
      step >= 1 ? 0 : static_cast<int>(std::ceil(-std::log10(step)));
  std::snprintf(buffer, sizeof(buffer), "%.*f", decimals,
                std::abs(v) < step * 1e-9 ? 0.0 : v);
  return buffer;
}

}  // namespace

cv::Point2d PlotFrame::ToPixel(double x, double y) const {
  const double u = area.x + (x - x_min) / (x_max - x_min) * area.width;
  const double v =
      area.y + area.height - (y - y_min) / (y_max - y_min) * area.height;
  return {u, v};
}

cv::Scalar SeriesColor(std::size_t i) {
  static const cv::Scalar kColors[] = {{180, 119, 31},  {14, 127, 255},
                                       {44, 160, 44},   {40, 39, 214},
                                       {189, 103, 148}, {75, 86, 140}};
  return kColors[i % (sizeof(kColors) / sizeof(kColors[0]))];
}

PlotFrame FitFrame(const std::vector<Series>& series,
                   const PlotOptions& options) {
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0,
         y1 = -x0;
  for (const Series& s : series) {
    for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]);
      y1 = std::max(y1, s.y[i]);
    }
  }
  if (!(x0 <= x1))
    throw Error("plot", "series", "", "nothing to plot: no finite point");
  // A flat or single-point series still gets a readable range.
  if (x1 - x0 < 1e-12) x1 = x0 + 1;
  if (y1 - y0 < 1e-12) {
    y0 -= 0.5;
    y1 += 0.5;
  }
  const double pad = 0.05 * (y1 - y0);
  PlotFrame frame;
  frame.area = cv::Rect(kMarginLeft, kMarginTop,
                        options.width - kMarginLeft - kMarginRight,
                        options.height - kMarginTop - kMarginBottom);
  frame.x_min = x0;
  frame.x_max = x1;
  frame.y_min = y0 - pad;
  frame.y_max = y1 + pad;
  return frame;
}

cv::Mat DrawPlot(const std::vector<Series>& series,
                 const PlotOptions& options) {
  const PlotFrame frame = FitFrame(series, options);
  cv::Mat image(options.height, options.width, CV_8UC3, kWhite);
  const cv::Rect& a = frame.area;

  // Grid and tick labels.
  const double x_step = NiceStep(frame.x_max - frame.x_min, 6);
  for (double x = std::ceil(frame.x_min / x_step) * x_step;
       x <= frame.x_max + 1e-9 * x_step; x += x_step) {
    const int u =
        static_cast<int>(std::lround(frame.ToPixel(x, frame.y_min).x));
    cv::line(image, {u, a.y}, {u, a.y + a.height}, kGrid, 1);
    const std::string text = TickText(x, x_step);
    const cv::Size size = cv::getTextSize(text, kFont, kFontScale, 1, nullptr);
    cv::putText(image, text, {u - size.width / 2, a.y + a.height + 20}, kFont,
                kFontScale, kBlack, 1, cv::LINE_AA);
  }
  const double y_step = NiceStep(frame.y_max - frame.y_min, 6);
  for (double y = std::ceil(frame.y_min / y_step) * y_step;
       y <= frame.y_max + 1e-9 * y_step; y += y_step) {
    const int v =
        static_cast<int>(std::lround(frame.ToPixel(frame.x_min, y).y));
    cv::line(image, {a.x, v}, {a.x + a.width, v}, kGrid, 1);
    const std::string text = TickText(y, y_step);
    const cv::Size size = cv::getTextSize(text, kFont, kFontScale, 1, nullptr);
    cv::putText(image, text, {a.x - size.width - 8, v + size.height / 2}, kFont,
                kFontScale, kBlack, 1, cv::LINE_AA);
  }
  cv::rectangle(image, a, kBlack, 1);
  for (const PlotMarker& m : options.markers) {
    if (!std::isfinite(m.x)) continue;
    const int u = static_cast<int>(std::lround(frame.ToPixel(m.x, 0).x));
    for (int v = a.y; v < a.y + a.height; v += 8)  // dashed
      cv::line(image, {u, v}, {u, std::min(v + 4, a.y + a.height)}, kBlack, 1);
    cv::putText(image, m.label, {u + 4, a.y + a.height - 8}, kFont, kFontScale,
                kBlack, 1, cv::LINE_AA);
  }

  // Series: a line through the points that exist (validation metrics are
  // recorded only every so often), a dot on each.
  for (std::size_t s = 0; s < series.size(); ++s) {
    std::vector<cv::Point> points;
    for (std::size_t i = 0;
         i < std::min(series[s].x.size(), series[s].y.size()); ++i) {
      if (!std::isfinite(series[s].x[i]) || !std::isfinite(series[s].y[i]))
        continue;
      const cv::Point2d p = frame.ToPixel(series[s].x[i], series[s].y[i]);
      points.emplace_back(static_cast<int>(std::lround(p.x)),
                          static_cast<int>(std::lround(p.y)));
    }
    if (points.size() > 1)
      cv::polylines(image, points, false, SeriesColor(s), 2, cv::LINE_AA);
    for (const cv::Point& p : points)
      cv::circle(image, p, 3, SeriesColor(s), cv::FILLED, cv::LINE_AA);
    // Legend entry.
    const int y = a.y + 12 + 22 * static_cast<int>(s);
    cv::line(image, {a.x + a.width + 16, y}, {a.x + a.width + 44, y},
             SeriesColor(s), 3, cv::LINE_AA);
    cv::putText(image, series[s].label, {a.x + a.width + 52, y + 5}, kFont,
                kFontScale, kBlack, 1, cv::LINE_AA);
  }

  // Title and axis labels (the y label sits above its axis: OpenCV does not
  // rotate text).
  cv::putText(image, options.title, {a.x, 24}, kFont, 0.6, kBlack, 1,
              cv::LINE_AA);
  cv::putText(image, options.y_label, {8, a.y - 10}, kFont, kFontScale, kBlack,
              1, cv::LINE_AA);
  const cv::Size x_label =
      cv::getTextSize(options.x_label, kFont, kFontScale, 1, nullptr);
  cv::putText(image, options.x_label,
              {a.x + (a.width - x_label.width) / 2, options.height - 16}, kFont,
              kFontScale, kBlack, 1, cv::LINE_AA);
  return image;
}

void PlotRunLog(
    const std::filesystem::path& csv, const std::filesystem::path& png,
    std::vector<std::string> columns, const std::string& title,
    const std::vector<std::pair<std::int64_t, std::string>>& marks) {
  const RunLog log = ReadRunLog(csv);
  if (columns.empty())
    columns.assign(log.columns.begin() + 2, log.columns.end());
  std::vector<Series> series;
  bool all_psnr = true;
  for (const std::string& name : columns) {
    const auto it = std::find(log.columns.begin(), log.columns.end(), name);
    if (it == log.columns.end()) {
      throw Error(csv.string(), "column", "\"" + name + "\"",
                  "not in the run log");
    }
    const std::size_t c = static_cast<std::size_t>(it - log.columns.begin());
    Series s;
    s.label = name;
    for (const auto& row : log.rows) {
      s.x.push_back(row[0].value_or(std::nan("")));
      s.y.push_back(row[c].value_or(std::nan("")));
    }
    all_psnr = all_psnr && name.find("psnr") != std::string::npos;
    series.push_back(std::move(s));
  }
  PlotOptions options;
  options.title = title.empty()
                      ? (log.stages.empty()
                             ? csv.filename().string()
                             : log.stages.front() + ": error against run time")
                      : title;
  options.y_label = all_psnr ? "PSNR (dB)" : "value";
  for (const auto& [iteration, label] : marks) {
    for (std::size_t r = 0; r < log.rows.size(); ++r) {
      if (log.iterations[r] == iteration && log.rows[r][0])
        options.markers.push_back({*log.rows[r][0], label});
    }
  }
  const cv::Mat image = DrawPlot(series, options);
  WritePng8(png, image);
}

}  // namespace pano4d
