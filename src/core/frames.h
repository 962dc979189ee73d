#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/core/posed_camera.h"

namespace pano4d {

// The frames every stage after `pano4d depth` works on, whatever the source
// (a dataset with known cameras, or a COLMAP workspace): WS/pano4d/frames.json.
// Cameras are pinhole (distortion was removed upstream) at the resolution of
// the images listed.
struct WorkspaceFrame {
  std::string name;  // unique, e.g. "0_00012"; names depth and mask files
  int time = 0;      // frame index in [0, num_times)
  PosedCamera camera;
  std::filesystem::path rgb;
  std::filesystem::path depth;         // z-depth .npy (H x W); empty: none
  std::filesystem::path dynamic_mask;  // PNG, 255 = dynamic; empty: none
  std::filesystem::path covisible;     // validation PNG; empty: none
};

// frames.json's depth_source: the dataset's own depth (rendered, a depth
// sensor), or depth pano4d estimated (stereo, or another tool's maps
// aligned to the SfM points).
inline constexpr const char* kDepthFromDataset = "dataset";
inline constexpr const char* kDepthFromStereo = "stereo";
inline constexpr const char* kDepthFromExternal = "external";
// Stereo where it has support on static pixels, a learned depth prior
// (--priors) aligned to the SfM points everywhere else.
inline constexpr const char* kDepthFromPriors = "stereo+priors";

struct WorkspaceFrames {
  std::string source;  // what the frames came from, for reports
  // Where the training depth came from: one of kDepthFrom*; empty in
  // frames.json written before it was stored.
  std::string depth_source;
  // The dataset the validation frames belong to (for `pano4d eval`), and
  // the resolution divisor they were loaded at; empty / 0 without one.
  std::filesystem::path dataset;
  int dataset_factor = 0;
  int num_times = 0;
  // The learned priors folder the depth stage read (--priors); the fit
  // reads its flow and disparity when not given another. Empty: none.
  std::filesystem::path priors;
  // The depth stage's options, for the record (null when not stored).
  nlohmann::json depth_options;
  std::vector<WorkspaceFrame> train;
  std::vector<WorkspaceFrame> val;  // held-out frames; may be empty

  // Throws pano4d::Error naming `source` and the frame: duplicate names,
  // times outside [0, num_times), num_times beyond the frame count,
  // non-pinhole cameras, no training frame.
  void Check(const std::string& source) const;
};

std::filesystem::path FramesPath(const std::filesystem::path& workspace);
// Paths inside the workspace are stored relative to it, others absolute;
// reading makes them absolute again.
void WriteWorkspaceFrames(const std::filesystem::path& workspace,
                          const WorkspaceFrames& frames);
// Throws pano4d::Error naming the file, with the remedy (`pano4d depth`)
// when it is missing.
WorkspaceFrames ReadWorkspaceFrames(const std::filesystem::path& workspace);

}  // namespace pano4d
