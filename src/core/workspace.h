#pragma once

// Every path under a pano4d workspace, in one place. A workspace is a COLMAP
// workspace (images/, masks/, database.db, sparse/) with pano4d's own files
// in pano4d/ and the report a person opens first in report/. Stages take a
// Workspace and never build these paths themselves; the README's
// "Workspace layout" lists the same files.

#include <filesystem>
#include <string>

namespace pano4d {

class Workspace {
 public:
  Workspace() = default;
  explicit Workspace(std::filesystem::path root) : root_(std::move(root)) {}

  const std::filesystem::path& root() const { return root_; }

  // COLMAP's part (`pano4d sfm` writes it; COLMAP's GUI opens it).
  std::filesystem::path images() const { return root_ / "images"; }
  std::filesystem::path colmap_masks() const { return root_ / "masks"; }
  std::filesystem::path database() const { return root_ / "database.db"; }
  std::filesystem::path sparse() const { return root_ / "sparse"; }

  // pano4d's part.
  std::filesystem::path pano4d() const { return root_ / "pano4d"; }
  // sfm: the model and images later stages use, step logs and stamps.
  std::filesystem::path sfm_json() const { return pano4d() / "sfm.json"; }
  std::filesystem::path logs() const { return pano4d() / "logs"; }
  std::filesystem::path image_list() const {
    return pano4d() / "image_list.txt";
  }
  std::filesystem::path known_model() const { return pano4d() / "known_model"; }
  std::filesystem::path undistorted() const { return pano4d() / "undistorted"; }
  // Dynamic masks (255 = moving) of the frames SfM saw, and of the
  // undistorted frames where those differ in size.
  std::filesystem::path dynamic_masks() const {
    return pano4d() / "tracks" / "dynamic";
  }
  std::filesystem::path undistorted_dynamic_masks() const {
    return pano4d() / "tracks" / "dynamic_undistorted";
  }
  // depth: the frames every later stage works on, and their depth maps.
  std::filesystem::path frames_json() const { return pano4d() / "frames.json"; }
  std::filesystem::path depth() const { return pano4d() / "depth"; }
  std::filesystem::path depth_map(const std::string& frame) const {
    return depth() / (frame + ".npy");
  }
  // Per stage the inputs it completed with (stamp.h).
  std::filesystem::path stamps() const { return pano4d() / "stamps"; }
  // run: the plan, the facts it was made from and per stage its status.
  std::filesystem::path plan_json() const { return pano4d() / "plan.json"; }
  // fit.
  std::filesystem::path checkpoint() const {
    return pano4d() / "checkpoints" / "fit.ckpt";
  }
  // The convergence stop's samples up to the checkpoint, saved with it.
  std::filesystem::path convergence_samples() const {
    return pano4d() / "checkpoints" / "convergence.json";
  }
  std::filesystem::path fit_json() const { return pano4d() / "fit.json"; }
  // `fit --force`: the fit it replaces, until the new one completes.
  std::filesystem::path previous_fit() const {
    return pano4d() / "previous_fit";
  }
  std::filesystem::path metrics() const { return pano4d() / "metrics"; }
  std::filesystem::path fit_csv() const { return metrics() / "fit.csv"; }
  std::filesystem::path fit_plot() const { return metrics() / "fit.png"; }
  std::filesystem::path metrics_json() const {
    return metrics() / "metrics.json";
  }
  std::filesystem::path sfm_ground_truth_json() const {
    return metrics() / "sfm_ground_truth.json";
  }
  // Renders: renders/val (the validation frames), renders/val_depth
  // (their z-depth, .npy), renders/<trajectory> (`pano4d render`).
  std::filesystem::path renders(const std::string& name) const {
    return pano4d() / "renders" / name;
  }
  std::filesystem::path val_renders() const { return renders("val"); }
  std::filesystem::path val_depth_renders() const {
    return renders("val_depth");
  }
  // The expansion inside fit, `pano4d expand`'s steps, the panoramas.
  std::filesystem::path expansion() const { return pano4d() / "expansion"; }
  std::filesystem::path trajectories_json() const {
    return expansion() / "trajectories.json";
  }
  std::filesystem::path expand() const { return pano4d() / "expand"; }
  std::filesystem::path panorama() const { return pano4d() / "panorama"; }
  // `pano4d export`'s default folder.
  std::filesystem::path export_dir() const { return pano4d() / "export"; }
  // What a person opens first after `pano4d run` or `demo`.
  std::filesystem::path report() const { return root_ / "report"; }

 private:
  std::filesystem::path root_;
};

}  // namespace pano4d
