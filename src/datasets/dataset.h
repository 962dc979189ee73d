#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "src/core/posed_camera.h"

namespace pano4d {

// The resolution divisor the benchmarks evaluate at: DyCheck's covisibility
// masks exist at 2x only, and the Nvidia protocol scores 480x270 (half of
// its 960x540 frames).
inline constexpr int kEvaluationFactor = 2;
// A factor that asks for the dataset's protocol: kEvaluationFactor, or 1 for
// Kubric-4D, which ships one resolution. Every stage of a dataset run
// defaults to it; LoadDataset resolves it (Dataset::factor says which).
inline constexpr int kProtocolFactor = 0;

// One loader interface for every benchmark: a dataset is a list of frames in
// a training and a validation split, each with its camera and files.
// kHeldOut: frames of a video or image folder held out of the fit (no
// benchmark of record).
enum class DatasetKind { kDyCheck, kNvidia, kKubric4D, kHeldOut };
std::string_view ToString(DatasetKind kind);

// What a dataset's depth files hold.
enum class DepthConvention {
  kZ,            // z-depth along the optical axis (DyCheck, pano4d synth)
  kRayDistance,  // distance along each pixel's ray (Kubric-4D)
};

struct DatasetFrame {
  std::string id;  // the dataset's own name, e.g. DyCheck "1_00042"
  int camera_id = 0;
  int time_id = 0;     // frame index t in [0, num_times)
  PosedCamera camera;  // at the loaded resolution
  std::filesystem::path rgb;
  std::filesystem::path depth;  // empty when the dataset has none
  DepthConvention depth_convention = DepthConvention::kZ;  // read: ReadDepth
  std::filesystem::path covisible;  // validation frames only; empty when absent
};

struct Dataset {
  DatasetKind kind = DatasetKind::kDyCheck;
  std::filesystem::path root;
  std::string scene;  // the scene's name: its folder's ("nvidia-balloon1")
  int factor = 1;  // resolution divisor of the loaded files (DyCheck: 1 or 2)
  double fps = 0.0;
  int num_times = 0;
  std::vector<DatasetFrame> train;
  std::vector<DatasetFrame> val;
  // Near and far planes in world units, when the dataset says (DyCheck's
  // scene.json near/far are in its normalised units and divided by scale).
  std::optional<double> near;
  std::optional<double> far;
  // DyCheck's normalisation (scene.json): normalised = (x - center) * scale;
  // and its orientation hints (extra.json), in normalised units.
  double scene_scale = 1.0;
  Eigen::Vector3d scene_center = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> lookat;
  std::optional<Eigen::Vector3d> up;
};

// What `pano4d dataset info` prints: kind, frame counts per split and camera,
// image sizes, and whether depth and covisible masks are present on disk.
nlohmann::json DatasetInfo(const Dataset& dataset);

// The protocol that ran, in one line: which cameras train and validate,
// how many frames each, at which size and factor ("train: camera 0..11, 12
// frames; val: camera 0, 12 frames; 480x270 (factor 2)"). The evaluation
// reports print it, so that a variant (Nvidia's 12 or 24 frames) is named.
std::string SplitDescription(const Dataset& dataset);

// Detects the layout of `root` and loads it; throws pano4d::Error naming the
// folder and saying which layouts were looked for when none matches.
Dataset LoadDataset(const std::filesystem::path& root,
                    int factor = kProtocolFactor);

}  // namespace pano4d
