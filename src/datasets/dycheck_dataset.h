#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "src/datasets/dataset.h"

namespace pano4d {

// The DyCheck iPhone layout (KAIR-BAIR/dycheck), which pano4d's synthetic
// scenes also use:
//   camera/<id>.json        one per frame, ids "<camera>_<time:05d>"
//   rgb/{1x,2x}/<id>.png    depth/{1x,2x}/<id>.npy (float32 H x W x 1, 0 =
//   invalid) covisible/2x/val/<id>.png splits/{train,val}.json {"frame_names",
//   "camera_ids", "time_ids"} dataset.json {"count", "num_exemplars", "ids",
//   "train_ids", "val_ids"} scene.json {"scale", "center", "near", "far"}
//   (near/far in normalised units) metadata.json {id: {"warp_id",
//   "appearance_id", "camera_id"}} extra.json {"factor", "fps", "bbox",
//   "lookat", "up"}

bool LooksLikeDyCheck(const std::filesystem::path& root);

// Loads cameras (rescaled to the `factor` folders) and splits. Image, depth
// and covisible files are not required to exist (`dataset info` reports
// which do); a frame named in a split without its camera file is an error.
Dataset ReadDyCheck(const std::filesystem::path& root, int factor);

// One entry of splits/<name>.json.
struct DyCheckSplitEntry {
  std::string id;  // the frame's file stem, e.g. "0_00012"
  int camera_id = 0;
  int time_id = 0;
};
// A split's frame_names, camera_ids and time_ids, checked: the same lengths,
// names usable as file names, time ids >= 0. Throws pano4d::Error naming
// `source` and the entry.
std::vector<DyCheckSplitEntry> ParseDyCheckSplit(const nlohmann::json& json,
                                                 const std::string& source);

// Numbers the frames' time ids 0..T-1 in their order when they leave gaps
// (a split of every tenth time, or one stray id of 100000, which would
// otherwise ask the motion model for a pose per missing time), logging a
// warning that names `source`. Returns T, the count of distinct times.
int MakeTimeIdsDense(std::vector<DatasetFrame*> frames,
                     const std::string& source);

// The metadata of a scene to write in DyCheck's layout.
struct DyCheckScene {
  struct Frame {
    int camera_id = 0;
    int time_id = 0;
    PosedCamera camera;  // at 1x
  };
  std::vector<Frame> train;
  std::vector<Frame> val;
  double scale = 1.0;  // scene.json: normalised = (x - center) * scale
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double near = 0.0;  // world units; written normalised
  double far = 0.0;
  double fps = 30.0;
  Eigen::Vector3d bbox_min =
      Eigen::Vector3d::Zero();  // extra.json, normalised units
  Eigen::Vector3d bbox_max = Eigen::Vector3d::Zero();
  Eigen::Vector3d lookat = Eigen::Vector3d::Zero();
  Eigen::Vector3d up = Eigen::Vector3d::UnitY();
};

std::string DyCheckFrameId(int camera_id, int time_id);

// Writes camera/, splits/, dataset.json, scene.json, metadata.json and
// extra.json (images are written by the caller), each atomically.
void WriteDyCheckMetadata(const std::filesystem::path& root,
                          const DyCheckScene& scene);

}  // namespace pano4d
