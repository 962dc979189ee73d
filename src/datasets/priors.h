#pragma once

// Learned priors that users compute with foundation models before fitting
// (monocular depth, optical flow, 2D tracks, object masks), read exactly as
// the preprocessing of DynamicNeRF, OmniMotion, Shape of Motion, MoSca and
// CoTracker writes them, at any resolution, and brought onto the run's
// frames: resized to each frame's size, flow vectors and track coordinates
// scaled with the image. Every value is checked where it is read: NaN or
// Inf, another aspect ratio or frame count, a flow between frames that do
// not exist is an error naming the file. docs/formats.md lists the layouts.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace pano4d {

enum class PriorKind { kDepth, kFlow, kTracks, kMasks };
const char* PriorKindName(PriorKind kind);  // "depth", "flow", ...

// What a depth prior's values are.
enum class DepthMeaning {
  // Inverse depth up to an unknown scale and shift per frame (MiDaS, Depth
  // Anything); aligned to the SfM points in inverse depth.
  kDisparity,
  // Metric z-depth, 0 = none; aligned to the SfM points by a scale.
  kMetricDepth,
};

// One layout found in a priors folder.
struct PriorLayout {
  PriorKind kind = PriorKind::kDepth;
  std::string name;   // "DynamicNeRF disp/", "OmniMotion raft_exhaustive/"
  std::string holds;  // what its values are, for the plan
  std::filesystem::path path;  // its folder, or its file (tracks)
  int files = 0;
  DepthMeaning meaning = DepthMeaning::kDisparity;  // depth layouts only
};

struct PriorsFolder {
  std::filesystem::path root;
  std::vector<PriorLayout> layouts;  // of each kind, the preferred first
  // The layouts of `kind`, preferred first (PriorsFolder's order).
  std::vector<const PriorLayout*> Of(PriorKind kind) const;
  nlohmann::json ToJson() const;
};

// The layouts pano4d reads, one line each, for errors and --help.
std::string KnownPriorLayouts();

// The layouts `dir` holds (unknown files and folders beside them are left
// alone: a dataset's own folder may be its priors folder). Throws
// pano4d::Error naming the folder when it is missing or holds none of the
// known layouts, saying what it found and which layouts are known.
PriorsFolder ScanPriors(const std::filesystem::path& dir);

// A frame of the video the priors were computed on. Tools name their files
// after the frame's image (000.png_001.png.npy, 00000.npy), so a prior file
// belongs to the frame whose image file name, image stem or pano4d name it
// carries; track files index frames by their position in the video.
// Readers take the video's frames in time order, those the run leaves out
// (held out, or not posed) with `used` false: their files are known and
// skipped, not refused.
struct PriorFrame {
  std::string name;             // the workspace's frame name
  std::filesystem::path image;  // its image file
  int width = 0, height = 0;    // the run's resolution
  bool used = true;
};

// A relative aspect-ratio difference above this is another framing, not a
// rescale: refused.
inline constexpr double kMaxAspectDifference = 0.01;

// The depth layout preferred among those found: metric depth (MoSca), then
// Shape of Motion's aligned disparity, UniDepth's, Depth Anything's and
// MiDaS' (DynamicNeRF).
struct DepthPrior {
  const PriorLayout* layout = nullptr;
  // Per frame (indices of `frames`), CV_32FC1 at the frame's size:
  // disparity, or z-depth with 0 = none; empty where the layout has no
  // file for the frame.
  std::vector<cv::Mat> maps;
  int source_width = 0, source_height = 0;  // the files' resolution
};

struct FlowField {
  int from = 0, to = 0;  // indices of the readers' `frames`
  // CV_32FC2 at `from`'s size, in its pixels: pixel x of `from` sees what
  // x + flow(x) of `to` sees.
  cv::Mat flow;
  // CV_8UC1, kMaskOn where the flow is trusted: the file's occlusion mask,
  // else DynamicNeRF's forward-backward check against the flow `to` ->
  // `from` when the layout has it, else everywhere.
  cv::Mat valid;
  std::string mask_source;  // "file", "forward-backward", "none"
};

// Flow between frames whose times differ by at most `max_gap`, from the
// preferred flow layout: DynamicNeRF's (masks given), MoSca's, OmniMotion's.
struct FlowPrior {
  const PriorLayout* layout = nullptr;
  std::vector<FlowField> fields;
  int source_width = 0, source_height = 0;
};

// 2D tracks over the frames: per track and frame (track-major,
// frames.size() entries a track) a pixel position at the frame's size and
// whether the tracker saw it there.
struct TrackPrior {
  const PriorLayout* layout = nullptr;
  int num_frames = 0;
  std::vector<Eigen::Vector2f> pixels;
  std::vector<std::uint8_t> visible;
  std::size_t size() const {
    return num_frames == 0 ? 0 : visible.size() / num_frames;
  }
};

// Moving-object masks (kMaskOn = moving) per frame at its size; empty
// where the layout has no file for the frame.
struct MaskPrior {
  const PriorLayout* layout = nullptr;
  std::vector<cv::Mat> masks;
};

// Each reader takes the preferred layout of its kind (none: nullopt), reads
// what it holds for the used frames and throws pano4d::Error naming the
// file for NaN or Inf, another aspect ratio, an unreadable file, a file
// that names no frame of the video (listing a few that are), and tracks
// over another number of frames. Used frames without a file are left empty
// (partial priors).
std::optional<DepthPrior> ReadDepthPrior(const PriorsFolder& folder,
                                         const std::vector<PriorFrame>& frames);
// Flow between used frames at most `max_gap` apart in the video.
std::optional<FlowPrior> ReadFlowPrior(const PriorsFolder& folder,
                                       const std::vector<PriorFrame>& frames,
                                       int max_gap = 1);
// Track coordinates are scaled from `source_width` x `source_height`, the
// resolution the tracker ran at (a track file does not say): another
// prior's of the same folder, else the frames' images when 0.
std::optional<TrackPrior> ReadTrackPrior(const PriorsFolder& folder,
                                         const std::vector<PriorFrame>& frames,
                                         int source_width = 0,
                                         int source_height = 0);
std::optional<MaskPrior> ReadMaskPrior(const PriorsFolder& folder,
                                       const std::vector<PriorFrame>& frames);

// The used frames a per-frame prior has no map for, for the plan; empty
// when it covers every one.
std::vector<std::string> FramesWithout(const std::vector<cv::Mat>& maps,
                                       const std::vector<PriorFrame>& frames);

}  // namespace pano4d
