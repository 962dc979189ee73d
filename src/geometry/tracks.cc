#include "src/geometry/tracks.h"

#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "src/core/error.h"
#include "src/core/strings.h"

namespace pano4d {
namespace {

cv::Mat Grey8(const cv::Mat& image, int index) {
  cv::Mat grey = image;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_RGB2GRAY);
  if (grey.channels() != 1) {
    throw Error("frame " + std::to_string(index), "channels",
                std::to_string(image.channels()), "expected 1 or 3");
  }
  cv::Mat out;
  grey.convertTo(out, CV_8U, grey.depth() == CV_8U ? 1.0 : 255.0);
  return out;
}

// Bilinear sample of a CV_32FC2 flow at continuous pixel coordinates
// (centres at +0.5); false outside the image.
bool SampleFlow(const cv::Mat& flow, const Eigen::Vector2f& p,
                Eigen::Vector2f* out) {
  const float x = p.x() - 0.5f, y = p.y() - 0.5f;
  if (!(x >= 0 && y >= 0 && x <= flow.cols - 1 && y <= flow.rows - 1))
    return false;
  const int x0 =
      std::min(static_cast<int>(x), flow.cols - 2 < 0 ? 0 : flow.cols - 2);
  const int y0 =
      std::min(static_cast<int>(y), flow.rows - 2 < 0 ? 0 : flow.rows - 2);
  const int x1 = std::min(x0 + 1, flow.cols - 1),
            y1 = std::min(y0 + 1, flow.rows - 1);
  const float fx = x - x0, fy = y - y0;
  const cv::Vec2f a = flow.at<cv::Vec2f>(y0, x0),
                  b = flow.at<cv::Vec2f>(y0, x1),
                  c = flow.at<cv::Vec2f>(y1, x0),
                  d = flow.at<cv::Vec2f>(y1, x1);
  for (int k = 0; k < 2; ++k) {
    (*out)[k] = (1 - fy) * ((1 - fx) * a[k] + fx * b[k]) +
                fy * ((1 - fx) * c[k] + fx * d[k]);
  }
  return true;
}

}  // namespace

void TrackOptions::Check() const {
  if (!(consistency_threshold > 0)) {
    throw Error("track options", "consistency_threshold",
                std::to_string(consistency_threshold), "must be positive");
  }
}

Tracks2D ChainTracks(int num_times, int reference,
                     const std::vector<Eigen::Vector2f>& seeds,
                     const std::vector<FlowLink>& links,
                     const TrackOptions& options) {
  options.Check();
  if (reference < 0 || reference >= num_times) {
    throw Error("tracks", "reference", std::to_string(reference),
                "outside the " + std::to_string(num_times) + " times");
  }
  Tracks2D tracks;
  tracks.num_times = num_times;
  tracks.reference_time = reference;
  const std::size_t n = seeds.size();
  const int times = num_times;
  tracks.pixels.assign(n * times, Eigen::Vector2f::Zero());
  tracks.valid.assign(n * times, 0);
  for (std::size_t i = 0; i < n; ++i) {
    tracks.pixels[i * times + reference] = seeds[i];
    tracks.valid[i * times + reference] = 1;
  }
  const float threshold = static_cast<float>(options.consistency_threshold);
  for (const FlowLink& link : links) {
    if (link.forward.empty() || link.from < 0 || link.to < 0 ||
        link.from >= times || link.to >= times)
      continue;
    for (std::size_t i = 0; i < n; ++i) {
      if (!tracks.valid[i * times + link.from]) continue;
      const Eigen::Vector2f p = tracks.pixels[i * times + link.from];
      Eigen::Vector2f f, b;
      if (!SampleFlow(link.forward, p, &f)) continue;
      const Eigen::Vector2f q = p + f;
      if (!link.backward.empty()) {
        if (!SampleFlow(link.backward, q, &b)) continue;
        if ((q + b - p).norm() > threshold) continue;
      } else if (!link.valid.empty()) {
        const int x = static_cast<int>(std::floor(p.x()));
        const int y = static_cast<int>(std::floor(p.y()));
        if (x < 0 || y < 0 || x >= link.valid.cols || y >= link.valid.rows ||
            !link.valid.at<std::uint8_t>(y, x))
          continue;
        if (!(q.x() >= 0 && q.y() >= 0 && q.x() < link.forward.cols &&
              q.y() < link.forward.rows))
          continue;
      }
      tracks.pixels[i * times + link.to] = q;
      tracks.valid[i * times + link.to] = 1;
    }
  }
  return tracks;
}

Tracks2D ChainFlowTracks(const std::vector<cv::Mat>& frames, int reference,
                         const std::vector<Eigen::Vector2f>& seeds,
                         const TrackOptions& options) {
  options.Check();
  const int times = static_cast<int>(frames.size());
  if (reference < 0 || reference >= times || frames[reference].empty()) {
    throw Error("tracks", "reference", std::to_string(reference),
                "no frame at the reference time");
  }
  std::vector<cv::Mat> grey(times);
  for (int t = 0; t < times; ++t) {
    if (frames[t].empty()) continue;
    if (frames[t].size() != frames[reference].size()) {
      throw Error("frame " + std::to_string(t), "size",
                  SizeText(frames[t].cols, frames[t].rows),
                  "differs from the reference frame's");
    }
    grey[t] = Grey8(frames[t], t);
  }
  // The links of each direction are independent flow computations; they
  // run in parallel, then the chaining is sequential.
  std::vector<FlowLink> links;
  for (int t = reference; t + 1 < times; ++t)
    links.push_back({t, t + 1, {}, {}, {}});
  for (int t = reference; t - 1 >= 0; --t)
    links.push_back({t, t - 1, {}, {}, {}});
  cv::parallel_for_(
      cv::Range(0, static_cast<int>(links.size())), [&](const cv::Range& r) {
        cv::Ptr<cv::DISOpticalFlow> dis =
            cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM);
        // The preset stops at half resolution; chained over the 24 links
        // from the canonical time to a clip's ends its sub-pixel error
        // drifts (docs/experiments/
        // 2026-11-23-full-resolution-tracks-and-static-scale-clamp.md).
        dis->setFinestScale(0);
        for (int l = r.start; l < r.end; ++l) {
          FlowLink& link = links[l];
          if (grey[link.from].empty() || grey[link.to].empty()) continue;
          dis->calc(grey[link.from], grey[link.to], link.forward);
          dis->calc(grey[link.to], grey[link.from], link.backward);
        }
      });
  return ChainTracks(times, reference, seeds, links, options);
}

}  // namespace pano4d
