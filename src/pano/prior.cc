#include "src/pano/prior.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <numeric>
#include <utility>

#include <opencv2/imgproc.hpp>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/strings.h"
#include "src/core/subprocess.h"
#include "src/geometry/inpaint.h"
#include "src/pano/trajectory.h"
#include "src/pano/warp.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// Step 1 warps only this many other frames, nearest in time, into each
// frame: content far away in time is the most likely to have moved, and the
// cost stays O(T k) warps instead of O(T^2).
constexpr int kNeighbourFrames = 4;
// cv::inpaint's neighbourhood (pixels): wide enough to average out one noisy
// boundary pixel, small enough to keep edges that run into the hole.
constexpr double kInpaintRadius = 3.0;
// The colour of a pixel nothing in the clip says anything about: neutral,
// so that a later refinement pulls it either way equally.
constexpr float kUnknownGrey = 0.5f;

// Checks that `mats[i]` is a `type` matrix of `sizes[i]`'s size (the counts
// are checked already).
void CheckPerFrame(const std::string& clip, const std::string& field,
                   const std::vector<cv::Mat>& mats, int type,
                   const char* type_name,
                   const std::vector<RasterCamera>& sizes) {
  for (std::size_t i = 0; i < mats.size(); ++i) {
    const cv::Mat& m = mats[i];
    if (m.type() != type || m.cols != sizes[i].width ||
        m.rows != sizes[i].height) {
      throw Error("prior clip " + clip, field + "[" + std::to_string(i) + "]",
                  SizeText(m.cols, m.rows),
                  std::string("expected ") + type_name +
                      " of its camera's size " +
                      SizeText(sizes[i].width, sizes[i].height));
    }
  }
}

// The known pixels of a frame as a warp source (mask 255 = hole; rgb and
// depth zeroed there, since a clip's holes hold arbitrary values).
WarpResult InitialState(const PriorClip& clip, std::size_t i) {
  WarpResult state;
  state.mask = clip.masks[i].clone();
  state.rgb = clip.frames[i].clone();
  state.rgb.setTo(cv::Scalar::all(0), state.mask);
  state.depth = clip.depth[i].clone();
  cv::patchNaNs(state.depth, 0);
  state.depth.setTo(
      0, state.mask | (state.depth < 0) |
             (state.depth == std::numeric_limits<float>::infinity()));
  return state;
}

bool HasHoles(const WarpResult& state) {
  return cv::countNonZero(state.mask) > 0;
}

// The other frames of the clip, nearest in time first (then nearest in
// order), at most `k`.
std::vector<std::size_t> NearestInTime(const std::vector<int>& times,
                                       std::size_t i, int k) {
  std::vector<std::size_t> order(times.size());
  std::iota(order.begin(), order.end(), 0);
  order.erase(order.begin() + static_cast<std::ptrdiff_t>(i));
  const auto key = [&](std::size_t j) {
    return std::make_pair(std::abs(static_cast<double>(times[j]) - times[i]),
                          std::abs(static_cast<double>(j) - i));
  };
  std::stable_sort(order.begin(), order.end(),
                   [&](auto a, auto b) { return key(a) < key(b); });
  if (order.size() > static_cast<std::size_t>(k)) order.resize(k);
  return order;
}

// Step 1: each frame's holes from the known pixels of its nearest frames.
void FillFromOtherFrames(const PriorClip& clip,
                         std::vector<WarpResult>* states) {
  for (std::size_t i = 0; i < states->size(); ++i) {
    WarpResult& into = (*states)[i];
    if (!HasHoles(into)) continue;
    for (std::size_t j : NearestInTime(clip.times, i, kNeighbourFrames)) {
      cv::Mat valid = (clip.masks[j] == 0) & (clip.depth[j] > 0);
      if (!clip.moving.empty()) valid &= clip.moving[j] == 0;
      if (!cv::countNonZero(valid)) continue;
      FillHoles(ForwardWarp(clip.frames[j], clip.depth[j], clip.cameras[j],
                            clip.cameras[i], valid),
                &into);
      if (!HasHoles(into)) break;
    }
  }
}

cv::Mat InpaintFloat(const cv::Mat& image, const cv::Mat& mask,
                     double max_value) {
  return InpaintTelea(image, mask, max_value, kInpaintRadius);
}

// The clip's moving pixels of frame i; empty when the clip has none.
cv::Mat MovingAt(const PriorClip& clip, std::size_t i) {
  return clip.moving.empty() ? cv::Mat() : clip.moving[i];
}

// The clip's layout of frame i (depth, colour); empty mats when it has none.
std::pair<cv::Mat, cv::Mat> LayoutAt(const PriorClip& clip, std::size_t i) {
  if (clip.layout_depth.empty()) return {};
  return {clip.layout_depth[i], clip.layout_rgb[i]};
}

// Fades inpainted colour toward the layout's with the distance to the
// nearest known pixel (`unknown`: 255 where not known): Telea's colour is a
// fair guess next to what it continues and a poor one far inside a hole,
// where the colour of the surface the ray meets errs less.
void FadeToLayout(const cv::Mat& unknown,
                  const std::pair<cv::Mat, cv::Mat>& layout, cv::Mat* rgb) {
  const auto& [depth, colour] = layout;
  cv::Mat distance;
  cv::distanceTransform(unknown, distance, cv::DIST_L2, 3);
  const double fade = kLayoutFadeShare * std::max(rgb->cols, rgb->rows);
  for (int y = 0; y < rgb->rows; ++y) {
    for (int x = 0; x < rgb->cols; ++x) {
      if (!unknown.at<std::uint8_t>(y, x) || !(depth.at<float>(y, x) > 0))
        continue;
      const auto w =
          static_cast<float>(std::exp(-distance.at<float>(y, x) / fade));
      cv::Vec3f& c = rgb->at<cv::Vec3f>(y, x);
      c = w * c + (1.0f - w) * colour.at<cv::Vec3f>(y, x);
    }
  }
}

// Steps 2 and 3: inpaints the state's holes, colour from its known static
// pixels (`moving`, when not empty, marks the others) and depth from their
// depth, no nearer than the layout's where there is one (0 stays where no
// depth is known at all). Returns false, leaving the frame alone, when
// nothing static in it is known.
bool InpaintHoles(WarpResult* state, const cv::Mat& moving,
                  const std::pair<cv::Mat, cv::Mat>& layout) {
  const cv::Mat& hole = state->mask;
  const cv::Mat unknown = moving.empty() ? hole : (hole | moving);
  if (cv::countNonZero(unknown) == static_cast<int>(unknown.total()))
    return false;
  cv::Mat rgb = InpaintFloat(state->rgb, unknown, 1.0);
  if (!layout.first.empty()) FadeToLayout(unknown, layout, &rgb);
  rgb.copyTo(state->rgb, hole);
  const cv::Mat no_depth = unknown | (state->depth <= 0);
  cv::Mat depth = cv::Mat::zeros(state->depth.size(), CV_32FC1);
  if (cv::countNonZero(no_depth) < static_cast<int>(no_depth.total()))
    depth = FillDepthFromFarthest(state->depth, no_depth);
  if (!layout.first.empty()) depth = cv::max(depth, layout.first);
  depth.copyTo(state->depth, hole);
  state->mask.setTo(0);
  return true;
}

// Step 2: the reference frame is inpainted and what it invented is warped,
// with its inpainted depth, into every other frame's remaining holes.
void PropagateReference(const PriorClip& clip,
                        std::vector<WarpResult>* states) {
  const std::size_t r = states->size() / 2;
  WarpResult& reference = (*states)[r];
  if (!HasHoles(reference)) return;
  const cv::Mat invented = reference.mask.clone();
  if (!InpaintHoles(&reference, MovingAt(clip, r), LayoutAt(clip, r))) return;
  for (std::size_t i = 0; i < states->size(); ++i) {
    if (i == r || !HasHoles((*states)[i])) continue;
    FillHoles(ForwardWarp(reference.rgb, reference.depth, clip.cameras[r],
                          clip.cameras[i], invented),
              &(*states)[i]);
  }
}

// Filled colour finite and in [0, 1] whatever the known pixels held (depth
// is finite and >= 0 from InitialState on).
void Sanitise(WarpResult* state) {
  cv::patchNaNs(state->rgb, kUnknownGrey);
  state->rgb = cv::min(cv::max(state->rgb, 0.0), 1.0);
}

std::string ReplaceAll(std::string text, const std::string& from,
                       const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos;
       at = text.find(from, at + to.size())) {
    text.replace(at, from.size(), to);
  }
  return text;
}

std::string ShellQuote(const std::string& text) {
  std::string quoted(1, '\'');  // appended, not `"'" + ...`: GCC 12 warns
  quoted += ReplaceAll(text, "'", "'\\''");  // falsely (-Wrestrict) there
  quoted += '\'';
  return quoted;
}

// A clip name as one folder name: no separators, no "..".
std::string FolderName(const std::string& name) {
  std::string folder = name;
  for (char& c : folder) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-')
      c = '_';
  }
  return folder.empty() ? "clip" : folder;
}

std::string FrameName(std::size_t i) {
  return ZeroPadded(static_cast<std::int64_t>(i), 5) + ".png";
}

// Writes {in}: frames (holes black), masks, references and meta.json.
void WriteCommandInput(const PriorClip& clip, const fs::path& in) {
  for (std::size_t i = 0; i < clip.frames.size(); ++i) {
    cv::Mat frame = clip.frames[i].clone();
    frame.setTo(cv::Scalar::all(0), clip.masks[i]);
    WriteImage(in / "frames" / FrameName(i), Image::FromRgb32f(frame));
    WriteMask(in / "masks" / FrameName(i), clip.masks[i]);
    WriteImage(in / "references" / FrameName(i),
               Image::FromRgb32f(clip.references[i]));
  }
  Json meta = {{"clip", clip.name},
               {"count", clip.frames.size()},
               {"width", clip.cameras.front().width},
               {"height", clip.cameras.front().height},
               {"times", clip.times},
               {"cameras", Json::array()},
               {"reference_cameras", Json::array()}};
  for (const RasterCamera& camera : clip.cameras) {
    meta["cameras"].push_back(CameraToJson(camera));
  }
  for (const RasterCamera& camera : clip.reference_cameras) {
    meta["reference_cameras"].push_back(CameraToJson(camera));
  }
  WriteJson(in / "meta.json", meta);
}

// Runs the shell command line in its own process group, output to `log`,
// stopped after `timeout_seconds` (0: no limit); returns the problem, empty
// when it exited 0.
std::string RunShell(const std::string& line, const fs::path& log,
                     double timeout_seconds) {
  const ProcessResult r =
      RunProcess({"/bin/sh", "-c", line}, log,
                 {.timeout_seconds = timeout_seconds, .own_group = true});
  if (r.ok()) return "";
  return ProcessFailure(r, log) + (r.timed_out ? " (--prior-timeout)" : "");
}

bool InUnitRange(const cv::Mat& m) {
  if (!cv::checkRange(m, true)) return false;
  double lo = 0, hi = 0;
  cv::minMaxLoc(m.reshape(1), &lo, &hi);
  return lo >= 0 && hi <= 1;
}

// Reads {out}/frames and checks count, decoding, size and range. Returns the
// problem, empty when every frame is fine.
std::string ReadCommandOutput(const PriorClip& clip, const fs::path& dir,
                              std::vector<cv::Mat>* frames) {
  const std::size_t count = clip.frames.size();
  std::size_t found = 0, pngs = 0;
  std::string first_missing;
  for (std::size_t i = 0; i < count; ++i) {
    if (fs::is_regular_file(dir / FrameName(i))) {
      ++found;
    } else if (first_missing.empty()) {
      first_missing = FrameName(i);
    }
  }
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (entry.path().extension() == ".png") ++pngs;
  }
  if (found < count) {
    return "found " + std::to_string(found) + " of " + std::to_string(count) +
           " frames in " + dir.string() + " (first missing: " + first_missing +
           ")";
  }
  if (pngs > count) {
    return "found " + std::to_string(pngs) + " frames in " + dir.string() +
           ", expected exactly " + std::to_string(count);
  }
  for (std::size_t i = 0; i < count; ++i) {
    const fs::path path = dir / FrameName(i);
    Image image;
    try {
      image = ReadImage(path);
    } catch (const Error& e) {
      return std::string("a frame does not decode: ") + e.what();
    }
    const std::string expected =
        SizeText(clip.cameras[i].width, clip.cameras[i].height);
    if (SizeText(image.width(), image.height()) != expected) {
      return "frame " + path.string() + " is " +
             SizeText(image.width(), image.height()) + ", expected " + expected;
    }
    if (!InUnitRange(image.mat())) {
      return "frame " + path.string() + " has values outside [0, 1]";
    }
    frames->push_back(image.mat());
  }
  return "";
}

}  // namespace

void PriorClip::Check() const {
  const std::size_t count = frames.size();
  if (count == 0) {
    throw Error("prior clip " + name, "frames", "0",
                "expected at least one frame");
  }
  const auto check_count = [&](const std::string& field, std::size_t n) {
    if (n != count) {
      throw Error("prior clip " + name, field, std::to_string(n),
                  "expected one entry per frame, " + std::to_string(count));
    }
  };
  check_count("masks", masks.size());
  check_count("depth", depth.size());
  check_count("cameras", cameras.size());
  check_count("times", times.size());
  check_count("references", references.size());
  check_count("reference_cameras", reference_cameras.size());
  CheckPerFrame(name, "frames", frames, CV_32FC3, "CV_32FC3", cameras);
  CheckPerFrame(name, "masks", masks, CV_8UC1, "CV_8UC1", cameras);
  CheckPerFrame(name, "depth", depth, CV_32FC1, "CV_32FC1", cameras);
  CheckPerFrame(name, "references", references, CV_32FC3, "CV_32FC3",
                reference_cameras);
  if (!moving.empty()) {
    check_count("moving", moving.size());
    CheckPerFrame(name, "moving", moving, CV_8UC1, "CV_8UC1", cameras);
  }
  if (!layout_depth.empty() || !layout_rgb.empty()) {
    check_count("layout_depth", layout_depth.size());
    check_count("layout_rgb", layout_rgb.size());
    CheckPerFrame(name, "layout_depth", layout_depth, CV_32FC1, "CV_32FC1",
                  cameras);
    CheckPerFrame(name, "layout_rgb", layout_rgb, CV_32FC3, "CV_32FC3",
                  cameras);
  }
}

PriorResult GeometryPrior::Fill(const PriorClip& clip) {
  clip.Check();
  const std::size_t count = clip.frames.size();
  std::vector<WarpResult> states;
  states.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    states.push_back(InitialState(clip, i));
  }
  FillFromOtherFrames(clip, &states);
  PropagateReference(clip, &states);
  int unknown = 0;
  for (std::size_t i = 0; i < count; ++i) {
    WarpResult& state = states[i];
    if (HasHoles(state) &&
        !InpaintHoles(&state, MovingAt(clip, i), LayoutAt(clip, i))) {
      state.rgb.setTo(cv::Scalar::all(kUnknownGrey), state.mask);
      ++unknown;
    }
    Sanitise(&state);
  }
  if (unknown > 0) {
    PANO4D_LOG(kWarning) << "geometry prior: clip " << clip.name << ": "
                         << unknown << " of " << count
                         << " frames have no known static pixel to fill "
                            "from (the clip is masked everywhere, or shows "
                            "only moving content); filled mid-grey";
  }
  PriorResult result;
  result.prior = name();
  for (std::size_t i = 0; i < count; ++i) {
    result.frames.push_back(
        Composite(clip.frames[i], states[i].rgb, clip.masks[i]));
    cv::Mat depth = clip.depth[i].clone();
    states[i].depth.copyTo(depth, clip.masks[i]);
    result.depth.push_back(depth);
  }
  return result;
}

CommandPrior::CommandPrior(std::string command, fs::path work_dir,
                           std::unique_ptr<Prior> fallback,
                           double timeout_seconds)
    : command_(std::move(command)),
      work_dir_(fs::absolute(work_dir)),
      fallback_(std::move(fallback)),
      timeout_seconds_(timeout_seconds) {
  if (command_.find("{in}") == std::string::npos ||
      command_.find("{out}") == std::string::npos) {
    throw Error("prior command", "template", "\"" + command_ + "\"",
                "must contain {in} and {out}: they are replaced by the folder "
                "it reads the clip from and the folder it writes frames/ to");
  }
}

PriorResult CommandPrior::Fill(const PriorClip& clip) {
  clip.Check();
  const fs::path work = work_dir_ / FolderName(clip.name);
  const fs::path in = work / "in", out = work / "out";
  const fs::path log = work / "command.log";
  std::string problem;
  try {
    std::error_code ec;
    fs::remove_all(work, ec);  // a previous run's frames must not pass
    if (ec)
      throw Error::In(work.string(), "cannot be cleared: " + ec.message());
    EnsureDirectory(in);
    EnsureDirectory(out);
    WriteCommandInput(clip, in);
    std::string line = ReplaceAll(command_, "{in}", ShellQuote(in.string()));
    line = ReplaceAll(line, "{out}", ShellQuote(out.string()));
    PANO4D_LOG(kInfo) << "prior command for clip " << clip.name << ": " << line;
    problem = RunShell(line, log, timeout_seconds_);
  } catch (const Error& e) {
    problem = std::string("cannot prepare its input: ") + e.what();
  }
  std::vector<cv::Mat> filled;
  if (problem.empty())
    problem = ReadCommandOutput(clip, out / "frames", &filled);
  if (problem.empty()) {
    PriorResult result;
    result.prior = name();
    for (std::size_t i = 0; i < filled.size(); ++i) {
      result.frames.push_back(
          Composite(clip.frames[i], filled[i], clip.masks[i]));
    }
    return result;
  }

  std::string reason = "prior command '";
  reason += command_;
  reason += "' for clip " + clip.name + ": " + problem;
  if (!fallback_) {
    throw Error("prior command", "clip", clip.name,
                reason + "; there is no fallback prior");
  }
  PANO4D_LOG(kError) << reason << "; falling back to the " << fallback_->name()
                     << " prior (inputs kept in " << work.string() << ")";
  PriorResult result = fallback_->Fill(clip);
  result.prior = fallback_->name();
  result.note = reason;
  return result;
}

cv::Mat Composite(const cv::Mat& warped, const cv::Mat& filled,
                  const cv::Mat& mask) {
  if (filled.type() != warped.type() || filled.size() != warped.size()) {
    throw Error("composite", "filled", SizeText(filled.cols, filled.rows),
                "expected the warped frame's size and type, " +
                    SizeText(warped.cols, warped.rows));
  }
  if (mask.type() != CV_8UC1 || mask.size() != warped.size()) {
    throw Error("composite", "mask", SizeText(mask.cols, mask.rows),
                "expected a CV_8UC1 mask of the warped frame's size " +
                    SizeText(warped.cols, warped.rows));
  }
  cv::Mat out = warped.clone();
  filled.copyTo(out, mask);
  return out;
}

std::unique_ptr<Prior> MakePrior(const std::string& command,
                                 const std::filesystem::path& work_dir,
                                 double timeout_seconds) {
  if (command.empty()) return std::make_unique<GeometryPrior>();
  return std::make_unique<CommandPrior>(
      command, work_dir, std::make_unique<GeometryPrior>(), timeout_seconds);
}

}  // namespace pano4d
