#include "src/geometry/motion_segmentation.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <set>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/median.h"
#include "src/core/option_checks.h"
#include "src/core/strings.h"
#include "src/core/timer.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// What one neighbour says about one pixel, as bits of a CV_8U map.
constexpr std::uint8_t kVotes = 1;     // flow lands inside and is consistent
constexpr std::uint8_t kViolates = 2;  // residual above the pair's threshold

// Frames whose pairs are computed together: enough parallel work for many
// cores, while the votes kept in memory stay bounded for long videos.
constexpr int kBlockFrames = 32;

std::string FrameName(std::size_t index) {
  return "frame " + std::to_string(index);
}

// Lengths in working pixels, from the options' diagonal fractions.
struct WorkingGeometry {
  cv::Size size;
  double diagonal = 0.0;
  double residual_px = 0.0;
  double consistency_px = 0.0;
  double static_motion_px = 0.0;

  int Radius(double fraction) const {
    return static_cast<int>(std::lround(fraction * diagonal));
  }
};

WorkingGeometry MakeGeometry(cv::Size frame, const DynamicMaskOptions& o) {
  const double scale = static_cast<double>(o.working_long_side) /
                       std::max(frame.width, frame.height);
  WorkingGeometry g;
  g.size = cv::Size(
      std::max(1, static_cast<int>(std::lround(frame.width * scale))),
      std::max(1, static_cast<int>(std::lround(frame.height * scale))));
  g.diagonal = std::hypot(g.size.width, g.size.height);
  g.residual_px = o.residual_threshold * g.diagonal;
  g.consistency_px = o.consistency_threshold * g.diagonal;
  g.static_motion_px = o.static_motion_threshold * g.diagonal;
  return g;
}

void CheckFrames(const std::vector<cv::Mat>& frames) {
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const cv::Mat& f = frames[i];
    if (f.empty()) throw Error::In(FrameName(i), "the frame is empty");
    const int depth = f.depth();
    if ((depth != CV_8U && depth != CV_16U && depth != CV_32F &&
         depth != CV_64F) ||
        (f.channels() != 1 && f.channels() != 3 && f.channels() != 4)) {
      throw Error(FrameName(i), "type", std::to_string(f.type()),
                  "expected 8-bit, 16-bit or float with 1, 3 or 4 channels");
    }
    if (f.size() != frames[0].size()) {
      throw Error(FrameName(i), "size", SizeText(f.cols, f.rows),
                  "expected " + SizeText(frames[0].cols, frames[0].rows) +
                      " like frame 0 (all frames of a video have one size)");
    }
  }
}

cv::Mat ToWorkingGrey(const cv::Mat& frame, cv::Size working) {
  cv::Mat grey = frame;
  if (frame.channels() == 3) cv::cvtColor(frame, grey, cv::COLOR_BGR2GRAY);
  if (frame.channels() == 4) cv::cvtColor(frame, grey, cv::COLOR_BGRA2GRAY);
  cv::Mat grey8;
  switch (grey.depth()) {
    case CV_8U:
      grey8 = grey;
      break;
    case CV_16U:
      grey.convertTo(grey8, CV_8U, 1.0 / 257.0);
      break;
    default:
      grey.convertTo(grey8, CV_8U, 255.0);
      break;
  }
  cv::Mat out;
  const bool shrink = working.area() < grey8.size().area();
  cv::resize(grey8, out, working, 0, 0,
             shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
  return out;
}

// The two-view model of an ordered pair (i -> j), in coordinates shifted to
// the image centre and divided by half the diagonal, which keeps the LMedS
// solvers' systems well conditioned (Hartley's normalisation).
struct PairModel {
  enum class Kind { kNone, kFundamental, kHomography, kStatic };
  Kind kind = Kind::kNone;
  cv::Matx33d M;                           // F or H, in normalised coordinates
  double cx = 0.0, cy = 0.0, scale = 1.0;  // normalised = (p - c) / scale
  double inlier_ratio = 0.0;
  double threshold_px = 0.0;  // violation threshold of this pair

  bool usable() const { return kind != Kind::kNone; }

  // The residual of the correspondence (x, y) -> (x + fx, y + fy), in
  // working pixels.
  double Residual(double x, double y, double fx, double fy) const {
    if (kind == Kind::kStatic) return std::hypot(fx, fy);
    const double u = (x - cx) / scale, v = (y - cy) / scale;
    const double u2 = u + fx / scale, v2 = v + fy / scale;
    const double a = M(0, 0) * u + M(0, 1) * v + M(0, 2);  // M x
    const double b = M(1, 0) * u + M(1, 1) * v + M(1, 2);
    const double c = M(2, 0) * u + M(2, 1) * v + M(2, 2);
    if (kind == Kind::kHomography) {
      if (c == 0.0) return std::numeric_limits<double>::infinity();
      return std::hypot(a / c - u2, b / c - v2) * scale;
    }
    // Sampson's first-order distance: x'^T F x over the gradient's norm.
    const double d = M(0, 0) * u2 + M(1, 0) * v2 + M(2, 0);  // F^T x'
    const double e = M(0, 1) * u2 + M(1, 1) * v2 + M(2, 1);
    const double den = a * a + b * b + d * d + e * e;
    if (den <= 0.0) return 0.0;
    return std::abs(u2 * a + v2 * b + c) / std::sqrt(den) * scale;
  }
};

// Correspondences of the consistent flow on a grid, in the model's
// normalised coordinates.
struct Grid {
  std::vector<cv::Point2f> from, to;
  std::vector<double> motion;  // flow length, working pixels
};

Grid SampleGrid(const cv::Mat& flow, const cv::Mat& votes, const PairModel& m,
                int step) {
  Grid grid;
  for (int y = step / 2; y < flow.rows; y += step) {
    for (int x = step / 2; x < flow.cols; x += step) {
      if (!votes.at<std::uint8_t>(y, x)) continue;
      const cv::Vec2f f = flow.at<cv::Vec2f>(y, x);
      const double u = x + 0.5, v = y + 0.5;
      grid.from.emplace_back((u - m.cx) / m.scale, (v - m.cy) / m.scale);
      grid.to.emplace_back((u + f[0] - m.cx) / m.scale,
                           (v + f[1] - m.cy) / m.scale);
      grid.motion.push_back(std::hypot(f[0], f[1]));
    }
  }
  return grid;
}

std::vector<double> GridResiduals(const PairModel& m, const Grid& grid) {
  std::vector<double> r(grid.from.size());
  for (std::size_t k = 0; k < r.size(); ++k) {
    const cv::Point2f& p = grid.from[k];
    const cv::Point2f& q = grid.to[k];
    r[k] = m.Residual(p.x * m.scale + m.cx, p.y * m.scale + m.cy,
                      (q.x - p.x) * m.scale, (q.y - p.y) * m.scale);
  }
  return r;
}

// The fraction of `residuals` below `threshold`.
double InlierRatio(const std::vector<double>& residuals, double threshold) {
  const auto n = std::count_if(residuals.begin(), residuals.end(),
                               [&](double r) { return r < threshold; });
  return static_cast<double>(n) / residuals.size();
}

// The homography of the grid by LMedS, or kind kNone when it fails.
PairModel FitHomography(PairModel model, const Grid& grid,
                        const DynamicMaskOptions& o) {
  const cv::Mat H = cv::findHomography(grid.from, grid.to, cv::LMEDS, 1.0,
                                       cv::noArray(), 2000, o.lmeds_confidence);
  // With more than seven points LMedS gives one 3x3 matrix or nothing.
  if (H.rows == 3 && H.cols == 3) {
    model.kind = PairModel::Kind::kHomography;
    H.convertTo(cv::Mat(3, 3, CV_64F, model.M.val), CV_64F);
  }
  return model;
}

// A camera below the static threshold is still, or held still by hand: its
// drift and tremor move the whole frame by about a pixel, which the flow
// magnitude would take for motion and answer with a wide noise threshold
// that hides a slow subject. The homography takes the place of the identity
// when it halves the typical residual (a tremor explained); a camera that
// truly stands still keeps the identity, which no outlier share can break
// (LMedS breaks down when moving objects cover half the grid).
constexpr double kTremorExplained = 0.5;

// Chooses and fits the two-view model of i -> j (kind kNone when the grid
// is too small or LMedS fails): the identity or a homography when the camera
// stands (nearly) still, else the fundamental matrix, or the homography when
// it explains the grid about as well (no parallax to define the epipolar
// geometry).
PairModel FitModel(PairModel model, const Grid& grid, const WorkingGeometry& g,
                   const DynamicMaskOptions& o) {
  if (static_cast<int>(grid.from.size()) < o.min_correspondences) return model;
  if (UpperMedian(grid.motion) < g.static_motion_px) {
    const PairModel held = FitHomography(model, grid, o);
    if (held.usable() && UpperMedian(GridResiduals(held, grid)) <
                             kTremorExplained * UpperMedian(grid.motion)) {
      return held;
    }
    model.kind = PairModel::Kind::kStatic;
    return model;
  }
  const cv::Mat F = cv::findFundamentalMat(grid.from, grid.to, cv::FM_LMEDS,
                                           1.0, o.lmeds_confidence);
  PairModel with_f = model;
  const PairModel with_h = FitHomography(model, grid, o);
  double f_inliers = -1.0, h_inliers = -1.0;
  if (F.rows == 3 && F.cols == 3) {
    with_f.kind = PairModel::Kind::kFundamental;
    F.convertTo(cv::Mat(3, 3, CV_64F, with_f.M.val), CV_64F);
    f_inliers = InlierRatio(GridResiduals(with_f, grid), g.residual_px);
  }
  if (with_h.usable()) {
    h_inliers = InlierRatio(GridResiduals(with_h, grid), g.residual_px);
  }
  if (h_inliers < 0.0) return with_f;  // kNone as well when F failed
  return h_inliers >= f_inliers - o.homography_margin ? with_h : with_f;
}

// The model of j -> i from that of i -> j, which saves the second LMedS.
PairModel Reversed(PairModel m) {
  if (m.kind == PairModel::Kind::kFundamental) m.M = m.M.t();
  if (m.kind == PairModel::Kind::kHomography) m.M = m.M.inv();
  return m;
}

// Sets the pair's threshold from the noise of its own grid, and drops the
// model when too few correspondences agree with it.
void Calibrate(PairModel* m, const Grid& grid, const WorkingGeometry& g,
               const DynamicMaskOptions& o) {
  if (!m->usable() ||
      static_cast<int>(grid.from.size()) < o.min_correspondences) {
    m->kind = PairModel::Kind::kNone;
    return;
  }
  const std::vector<double> residuals = GridResiduals(*m, grid);
  // Rousseeuw's robust scale of LMedS residuals.
  const double sigma =
      1.4826 * (1.0 + 5.0 / (residuals.size() - 7.0)) * UpperMedian(residuals);
  m->threshold_px = std::max(g.residual_px, o.noise_factor * sigma);
  m->inlier_ratio = InlierRatio(residuals, m->threshold_px);
  if (m->inlier_ratio < o.min_inlier_ratio) m->kind = PairModel::Kind::kNone;
}

// Where the flow i -> j lands inside frame j and comes back with the flow
// j -> i: 1 (the pixel can be judged), else 0 (occluded, or flow unreliable).
cv::Mat ConsistentPixels(const cv::Mat& flow_ij, const cv::Mat& flow_ji,
                         const WorkingGeometry& g) {
  const int w = flow_ij.cols, h = flow_ij.rows;
  cv::Mat map(h, w, CV_32FC2);
  for (int y = 0; y < h; ++y) {
    const cv::Vec2f* f = flow_ij.ptr<cv::Vec2f>(y);
    cv::Vec2f* m = map.ptr<cv::Vec2f>(y);
    for (int x = 0; x < w; ++x) m[x] = cv::Vec2f(x + f[x][0], y + f[x][1]);
  }
  cv::Mat back;
  cv::remap(flow_ji, back, map, cv::noArray(), cv::INTER_LINEAR,
            cv::BORDER_REPLICATE);
  cv::Mat votes = cv::Mat::zeros(h, w, CV_8U);
  const float max_x = w - 1.0f, max_y = h - 1.0f;
  const double limit2 = g.consistency_px * g.consistency_px;
  for (int y = 0; y < h; ++y) {
    const cv::Vec2f* f = flow_ij.ptr<cv::Vec2f>(y);
    const cv::Vec2f* b = back.ptr<cv::Vec2f>(y);
    const cv::Vec2f* m = map.ptr<cv::Vec2f>(y);
    std::uint8_t* out = votes.ptr<std::uint8_t>(y);
    for (int x = 0; x < w; ++x) {
      const bool inside =
          m[x][0] >= 0 && m[x][1] >= 0 && m[x][0] <= max_x && m[x][1] <= max_y;
      const double ex = f[x][0] + b[x][0], ey = f[x][1] + b[x][1];
      if (inside && ex * ex + ey * ey <= limit2) out[x] = kVotes;
    }
  }
  return votes;
}

struct Verdict {
  cv::Mat bits;  // CV_8U, kVotes | kViolates
  PairModel model;
};

// Marks the voting pixels whose residual exceeds the model's threshold.
void MarkViolations(const cv::Mat& flow, Verdict* v) {
  if (!v->model.usable()) {
    v->bits.setTo(0);
    return;
  }
  for (int y = 0; y < flow.rows; ++y) {
    const cv::Vec2f* f = flow.ptr<cv::Vec2f>(y);
    std::uint8_t* bits = v->bits.ptr<std::uint8_t>(y);
    for (int x = 0; x < flow.cols; ++x) {
      if (bits[x] && v->model.Residual(x + 0.5, y + 0.5, f[x][0], f[x][1]) >
                         v->model.threshold_px) {
        bits[x] |= kViolates;
      }
    }
  }
}

// Both frames' verdicts on each other, from the flows a -> b and b -> a.
void JudgePair(const cv::Mat& flow_ab, const cv::Mat& flow_ba,
               const WorkingGeometry& g, const DynamicMaskOptions& o,
               Verdict* ab, Verdict* ba) {
  PairModel frame;
  frame.cx = flow_ab.cols / 2.0;
  frame.cy = flow_ab.rows / 2.0;
  frame.scale = g.diagonal / 2.0;
  ab->bits = ConsistentPixels(flow_ab, flow_ba, g);
  ba->bits = ConsistentPixels(flow_ba, flow_ab, g);
  const Grid grid_ab = SampleGrid(flow_ab, ab->bits, frame, o.grid_step);
  const Grid grid_ba = SampleGrid(flow_ba, ba->bits, frame, o.grid_step);
  ab->model = FitModel(frame, grid_ab, g, o);
  ba->model = Reversed(ab->model);
  Calibrate(&ab->model, grid_ab, g, o);
  Calibrate(&ba->model, grid_ba, g, o);
  MarkViolations(flow_ab, ab);
  MarkViolations(flow_ba, ba);
}

// A majority of the voting neighbours, and at least two where two vote: an
// occlusion or a local flow error fools one of them, a moving object most.
cv::Mat CombineVotes(const std::vector<const cv::Mat*>& votes, cv::Size size,
                     double agreement) {
  cv::Mat dynamic = cv::Mat::zeros(size, CV_8U);
  if (votes.empty()) return dynamic;
  // needed[n]: violations that make a pixel with n voters dynamic.
  std::vector<int> needed(votes.size() + 1);
  for (std::size_t n = 1; n < needed.size(); ++n) {
    needed[n] = std::max(std::min<int>(n, 2),
                         static_cast<int>(std::ceil(agreement * n - 1e-9)));
  }
  std::vector<const std::uint8_t*> rows(votes.size());
  for (int y = 0; y < size.height; ++y) {
    for (std::size_t k = 0; k < votes.size(); ++k) rows[k] = votes[k]->ptr(y);
    std::uint8_t* out = dynamic.ptr<std::uint8_t>(y);
    for (int x = 0; x < size.width; ++x) {
      int voters = 0, violations = 0;
      for (const std::uint8_t* r : rows) {
        voters += r[x] & kVotes;
        violations += (r[x] & kViolates) ? 1 : 0;
      }
      if (voters > 0 && violations >= needed[voters]) out[x] = 255;
    }
  }
  return dynamic;
}

void Morph(cv::Mat* mask, int op, int radius, bool outside_static) {
  if (radius <= 0) return;
  const cv::Mat kernel = cv::getStructuringElement(
      cv::MORPH_ELLIPSE, cv::Size(2 * radius + 1, 2 * radius + 1));
  cv::morphologyEx(
      *mask, *mask, op, kernel, cv::Point(-1, -1), 1,
      outside_static ? cv::BORDER_CONSTANT : cv::BORDER_DEFAULT,
      outside_static ? cv::Scalar(0) : cv::morphologyDefaultBorderValue());
}

cv::Mat CleanUp(cv::Mat mask, const WorkingGeometry& g,
                const DynamicMaskOptions& o, cv::Size frame_size) {
  // The opening takes the outside as static, which also removes slivers
  // along the image border, where flow is least reliable; the closing and
  // dilation ignore the outside, so objects cut by the border keep their
  // extent there.
  Morph(&mask, cv::MORPH_OPEN, g.Radius(o.opening_radius), true);
  Morph(&mask, cv::MORPH_CLOSE, g.Radius(o.closing_radius), false);
  Morph(&mask, cv::MORPH_DILATE, g.Radius(o.dilation_radius), false);
  cv::Mat resized;
  cv::resize(mask, resized, frame_size, 0, 0, cv::INTER_LINEAR);
  return resized >= 128;
}

// Frame i's mask from its verdicts (slot 2k: frame i - gaps[k], slot
// 2k + 1: frame i + gaps[k]), and its statistics.
cv::Mat FrameMask(const std::vector<Verdict>& verdicts, int i, int n,
                  const WorkingGeometry& g, const DynamicMaskOptions& o,
                  cv::Size frame_size, DynamicMaskFrameStats* s) {
  std::vector<const cv::Mat*> votes;
  for (std::size_t k = 0; k < verdicts.size(); ++k) {
    const int j = i + (k % 2 ? 1 : -1) * o.frame_gaps[k / 2];
    if (j < 0 || j >= n) continue;
    ++s->neighbours;
    const PairModel& model = verdicts[k].model;
    if (!model.usable()) continue;
    ++s->neighbours_used;
    s->inlier_ratio += model.inlier_ratio;
    s->static_camera |= model.kind == PairModel::Kind::kStatic;
    s->homography |= model.kind == PairModel::Kind::kHomography;
    votes.push_back(&verdicts[k].bits);
  }
  if (s->neighbours_used > 0) s->inlier_ratio /= s->neighbours_used;
  cv::Mat mask =
      CleanUp(CombineVotes(votes, g.size, o.agreement), g, o, frame_size);
  s->dynamic_fraction =
      static_cast<double>(cv::countNonZero(mask)) / frame_size.area();
  return mask;
}

// Consecutive pairs whose flow decides whether the camera is held still:
// spread over the video, a handful of flows (milliseconds each).
constexpr int kStillProbePairs = 8;

// The median, over up to kStillProbePairs consecutive pairs spread over the
// video, of the median flow length on the grid, below the static threshold.
bool HeldStill(const std::vector<cv::Mat>& frames, const WorkingGeometry& g,
               const DynamicMaskOptions& o) {
  const int pairs = static_cast<int>(frames.size()) - 1;
  if (pairs < 1) return false;
  const int probes = std::min(pairs, kStillProbePairs);
  std::vector<double> medians(probes);
  cv::parallel_for_(cv::Range(0, probes), [&](const cv::Range& r) {
    cv::Ptr<cv::DISOpticalFlow> dis =
        cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM);
    for (int p = r.start; p < r.end; ++p) {
      const int t = probes > 1 ? p * (pairs - 1) / (probes - 1) : 0;
      cv::Mat flow;
      dis->calc(ToWorkingGrey(frames[t], g.size),
                ToWorkingGrey(frames[t + 1], g.size), flow);
      const cv::Mat every_pixel = cv::Mat::ones(flow.size(), CV_8U);
      const std::vector<double> lengths =
          SampleGrid(flow, every_pixel, PairModel{}, o.grid_step).motion;
      medians[p] = lengths.empty() ? 0.0 : UpperMedian(lengths);
    }
  });
  return UpperMedian(medians) < g.static_motion_px;
}

// The options for this video: a camera held still gets the longer gaps and
// the narrower margin.
DynamicMaskOptions ForVideo(const DynamicMaskOptions& o, bool held_still) {
  if (!held_still) return o;
  DynamicMaskOptions out = o;
  for (int gap : o.still_camera_gaps) {
    if (std::find(out.frame_gaps.begin(), out.frame_gaps.end(), gap) ==
        out.frame_gaps.end())
      out.frame_gaps.push_back(gap);
  }
  out.dilation_radius = o.still_camera_dilation_radius;
  return out;
}

}  // namespace

void DynamicMaskOptions::Check() const {
  const auto fail = [](const char* field, const std::string& value,
                       const std::string& problem) {
    throw Error("dynamic mask options", field, value, problem);
  };
  if (frame_gaps.empty()) {
    fail("frame_gaps", "{}", "at least one gap is needed");
  }
  std::set<int> seen;
  for (int gap : frame_gaps) {
    if (gap <= 0 || !seen.insert(gap).second) {
      fail("frame_gaps", std::to_string(gap),
           "gaps must be positive and unique");
    }
  }
  if (working_long_side < 32) {
    fail("working_long_side", std::to_string(working_long_side),
         "must be >= 32 pixels");
  }
  const auto fraction = [&](const char* field, double v, bool zero_ok) {
    if (!(v >= 0.0 && v < 1.0) || (!zero_ok && v == 0.0)) {
      fail(field, std::to_string(v),
           std::string(zero_ok ? "must be in [0, 1)" : "must be in (0, 1)") +
               " (a fraction of the image diagonal)");
    }
  };
  fraction("residual_threshold", residual_threshold, false);
  fraction("consistency_threshold", consistency_threshold, false);
  fraction("static_motion_threshold", static_motion_threshold, true);
  fraction("opening_radius", opening_radius, true);
  fraction("closing_radius", closing_radius, true);
  fraction("dilation_radius", dilation_radius, true);
  fraction("still_camera_dilation_radius", still_camera_dilation_radius, true);
  for (int gap : still_camera_gaps) {
    if (gap <= 0) {
      fail("still_camera_gaps", std::to_string(gap), "gaps must be positive");
    }
  }
  CheckNonNegative(noise_factor, "dynamic mask options", "noise_factor");
  if (!(agreement > 0.0 && agreement <= 1.0)) {
    fail("agreement", std::to_string(agreement), "must be in (0, 1]");
  }
  if (grid_step < 1) {
    fail("grid_step", std::to_string(grid_step), "must be >= 1 pixel");
  }
  if (min_correspondences < 8) {
    fail("min_correspondences", std::to_string(min_correspondences),
         "must be >= 8 (LMedS needs eight points for one solution)");
  }
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0)) {
    fail("min_inlier_ratio", std::to_string(min_inlier_ratio),
         "must be in [0, 1]");
  }
  if (!(lmeds_confidence > 0.0 && lmeds_confidence < 1.0)) {
    fail("lmeds_confidence", std::to_string(lmeds_confidence),
         "must be in (0, 1)");
  }
  if (!(homography_margin >= 0.0 && homography_margin <= 1.0)) {
    fail("homography_margin", std::to_string(homography_margin),
         "must be in [0, 1]");
  }
}

double DynamicMaskStats::MeanDynamicFraction() const {
  if (frames.empty()) return 0.0;
  double sum = 0.0;
  for (const DynamicMaskFrameStats& f : frames) sum += f.dynamic_fraction;
  return sum / frames.size();
}

std::string DynamicMaskStats::BriefReport() const {
  double max_fraction = 0.0;
  int still = 0, homography = 0, unjudged = 0;
  for (const DynamicMaskFrameStats& f : frames) {
    max_fraction = std::max(max_fraction, f.dynamic_fraction);
    still += f.static_camera ? 1 : 0;
    homography += f.homography ? 1 : 0;
    unjudged += f.neighbours_used == 0 ? 1 : 0;
  }
  char line[360];
  std::snprintf(line, sizeof(line),
                "dynamic masks: %zu frames, dynamic %.1f%% mean, %.1f%% max; "
                "static camera in %d, homography in %d, no usable neighbour "
                "in %d%s; %.2f s",
                frames.size(), 100.0 * MeanDynamicFraction(),
                100.0 * max_fraction, still, homography, unjudged,
                held_still ? "; camera held still (longer gaps)" : "", seconds);
  return line;
}

std::vector<cv::Mat> ComputeDynamicMasks(const std::vector<cv::Mat>& frames,
                                         const DynamicMaskOptions& given,
                                         DynamicMaskStats* stats) {
  Timer timer;
  given.Check();
  CheckFrames(frames);
  const int n = static_cast<int>(frames.size());
  std::vector<DynamicMaskFrameStats> frame_stats(n);
  std::vector<cv::Mat> masks(n);
  const cv::Size frame_size = n > 0 ? frames[0].size() : cv::Size();
  const WorkingGeometry g =
      n > 0 ? MakeGeometry(frame_size, given) : WorkingGeometry{};
  const bool held_still = HeldStill(frames, g, given);
  const DynamicMaskOptions options = ForVideo(given, held_still);
  const std::vector<int>& gaps = options.frame_gaps;
  const int slots = 2 * static_cast<int>(gaps.size());  // t - gap, t + gap

  const int max_gap = *std::max_element(gaps.begin(), gaps.end());

  // Blocks of frames, so that memory does not grow with the video: a pair
  // (a, a + gap) is computed in the block of a, once, its flows both ways
  // serving both frames; after its block, a frame has all of its votes.
  std::vector<cv::Mat> grey(n);
  std::vector<std::vector<Verdict>> verdicts(n);
  for (int start = 0; start < n; start += kBlockFrames) {
    const int end = std::min(n, start + kBlockFrames);
    const int last = std::min(n, end + max_gap);
    cv::parallel_for_(cv::Range(start, last), [&](const cv::Range& r) {
      for (int i = r.start; i < r.end; ++i) {
        if (grey[i].empty()) grey[i] = ToWorkingGrey(frames[i], g.size);
        verdicts[i].resize(slots);
      }
    });
    struct Pair {
      int a, b, gap_index;
    };
    std::vector<Pair> pairs;
    for (int a = start; a < end; ++a) {
      for (int gi = 0; gi < static_cast<int>(gaps.size()); ++gi) {
        if (a + gaps[gi] < n) pairs.push_back({a, a + gaps[gi], gi});
      }
    }
    cv::parallel_for_(
        cv::Range(0, static_cast<int>(pairs.size())), [&](const cv::Range& r) {
          cv::Ptr<cv::DISOpticalFlow> dis =
              cv::DISOpticalFlow::create(cv::DISOpticalFlow::PRESET_MEDIUM);
          cv::Mat flow_ab, flow_ba;
          for (int p = r.start; p < r.end; ++p) {
            const Pair& pair = pairs[p];
            flow_ab.release();  // DIS would take a filled flow as its start
            flow_ba.release();
            dis->calc(grey[pair.a], grey[pair.b], flow_ab);
            dis->calc(grey[pair.b], grey[pair.a], flow_ba);
            JudgePair(flow_ab, flow_ba, g, options,
                      &verdicts[pair.a][2 * pair.gap_index + 1],
                      &verdicts[pair.b][2 * pair.gap_index]);
          }
        });
    cv::parallel_for_(cv::Range(start, end), [&](const cv::Range& r) {
      for (int i = r.start; i < r.end; ++i) {
        masks[i] = FrameMask(verdicts[i], i, n, g, options, frame_size,
                             &frame_stats[i]);
        verdicts[i] = {};
        grey[i].release();
      }
    });
  }
  if (stats) {
    stats->held_still = held_still;
    stats->frames = std::move(frame_stats);
    stats->seconds = timer.WallSeconds();
  }
  return masks;
}

}  // namespace pano4d
