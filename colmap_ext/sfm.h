#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "colmap_ext/sfm_diagnosis.h"
#include "src/core/posed_camera.h"

namespace pano4d {

// `pano4d sfm`: camera poses and sparse points for a video or an image
// folder, with the colmap command-line tool, as one more stage of a COLMAP
// workspace (DESIGN.md: WS/images, WS/masks, WS/database.db, WS/sparse/0).
// A frame whose camera is known (a dataset's, or synthetic ground truth).
struct KnownFrame {
  std::filesystem::path image;
  std::string name;  // its name in WS/images, e.g. "0_00012.png"
  PosedCamera camera;
};

struct SfmOptions {
  // The input: exactly one of a video file, a folder of images, or frames
  // with known cameras (then the poses are kept and colmap
  // point_triangulator adds sparse points for them instead of the mapper).
  std::filesystem::path video;
  std::filesystem::path images;
  std::vector<KnownFrame> known;
  std::filesystem::path workspace;
  std::string camera_model = "SIMPLE_RADIAL";  // COLMAP's name
  // "sequential" (consecutive frames, for videos) or "exhaustive" (every
  // pair); empty: sequential for a video, exhaustive for images.
  std::string matcher;
  int stride = 1;      // keep every stride-th frame
  int max_frames = 0;  // 0: all
  int max_size = 0;    // longest side in pixels after resizing; 0: as is
  bool dynamic_masks = true;
  // One camera shared by all frames (a video, or photos from one camera);
  // false: one camera per image, as COLMAP's default.
  bool single_camera = true;
  bool force = false;  // redo steps whose outputs are already complete
  std::filesystem::path colmap;  // the executable; empty: from PATH

  // Throws pano4d::Error naming the wrong field.
  void Check() const;
  // Every option (known frames as their count), as sfm.json records them.
  nlohmann::json ToJson() const;
};

struct SfmStepReport {
  std::string step;
  double seconds = 0.0;
  bool skipped = false;  // outputs were complete from an earlier run
  std::string why;       // why it ran (StageStamp::Decide); empty if skipped
};

struct SfmReport {
  int frames = 0;
  int registered = 0;
  // Of those, frames the mapper left out and register_left_out.h posed.
  int posed_by_pnp = 0;
  int points3D = 0;
  double mean_reprojection_error = 0.0;  // pixels, mean over the 3D points
  int models = 0;                        // models the mapper produced
  std::filesystem::path model;           // the model later stages use
  std::filesystem::path images;          // the images that model refers to
  double mean_dynamic_fraction = 0.0;
  // The frames match by homographies that rotations explain: the model is
  // the rotation-only one (a pan: one centre, no points).
  bool rotation_only = false;
  // A rotation-only model whose rotations all agree: a camera on a tripod.
  bool static_camera = false;
  // "general", "rotation-only" or "static camera", as sfm.json says.
  std::string CameraMotion() const;
  // The share of frames posed and, for those left out, why.
  SfmDiagnosis diagnosis;
  std::vector<SfmStepReport> steps;
};

// Runs the steps that are not complete yet: frames, dynamic masks, colmap
// feature_extractor, matcher, mapper (the largest model becomes
// WS/sparse/0; instead, when nearly every verified pair fits a homography
// and rotations alone explain the matches, the rotation-only model of
// src/geometry/rotation_only.h), the frames it left out posed by PnP
// (register_left_out.h), image_undistorter
// when the camera model has distortion.
// Writes WS/pano4d/sfm.json (with posed_fraction and the diagnosis of the
// unposed frames) and WS/pano4d/logs/timings.json. Throws
// pano4d::Error naming the failed step, its log and the likely remedy.
SfmReport RunSfm(const SfmOptions& options);

}  // namespace pano4d
