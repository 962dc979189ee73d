#pragma once

// The render and export stages: novel-view videos of a fitted scene (orbit,
// spiral, bullet time, or a camera file), and the scene as 3DGS PLY per time
// step with its cameras as a COLMAP model.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "src/core/workspace.h"

namespace pano4d {

// Default arcs: a full orbit, a 10-degree circle (a gentle "spiral" around
// the input view, which stays where the capture has content), a 60-degree
// bullet-time swing.
inline constexpr double kOrbitDegrees = 360.0;
inline constexpr double kSpiralDegrees = 10.0;
inline constexpr double kBulletDegrees = 60.0;

// More frames than an hour at 30 fps is a typo: the cameras alone are
// built before the first frame.
inline constexpr int kMaxRenderFrames = 108000;

struct RenderOptions {
  // orbit, spiral, bullet, or a camera file
  // ({"views": [{"camera": {...}, "t": T}]}).
  std::string trajectory = "orbit";
  int time = -1;       // bullet time, or every view of a file's; -1: middle
  int frames = 60;     // of orbit, spiral, bullet
  double degrees = 0;  // 0: the path's default (kOrbitDegrees, ...)
  double fps = 10.0;
  std::filesystem::path out;  // empty: WS/pano4d/renders/<trajectory>
};

struct RenderSummary {
  std::string name;  // the trajectory's
  std::filesystem::path out;
  std::size_t frames = 0;
  std::filesystem::path video;     // empty when no MP4 could be written
  std::vector<std::string> notes;  // what was not written, and why
  std::string FullReport() const;
};

// Writes OUT/00000.png ..., OUT/<trajectory>.mp4 and OUT/cameras.json (the
// cameras in the camera-file layout, to edit and render again).
RenderSummary RunRender(const Workspace& workspace,
                        const RenderOptions& options);

// The PLY sequence's manifest (OUT/ply/sequence.json) and the frame rate
// it suggests, render's default --fps.
inline constexpr const char* kPlySequenceManifest = "sequence.json";
inline constexpr double kExportFps = 10.0;

struct ExportOptions {
  std::filesystem::path out;  // empty: WS/pano4d/export
};

struct ExportSummary {
  std::filesystem::path out;
  int ply_files = 0;
  std::size_t gaussians = 0;  // per file
  bool motion = false;        // one file per time step
  std::size_t training_cameras = 0, expanded_cameras = 0;
  std::filesystem::path manifest;   // OUT/ply/sequence.json
  std::uint64_t ply_bytes = 0;      // all PLY files
  std::uint64_t scene4d_bytes = 0;  // scene4d.json + scene4d.bin
  std::string FullReport() const;
};

// Writes OUT/ply/t_<time>.ply (OUT/ply/static.ply without motion) and
// their manifest OUT/ply/sequence.json ({"format": "pano4d-ply-sequence",
// "fps", "frames": [{"file", "time"}], ...}: the same Gaussians in the
// same order in every file), the compact 4D scene OUT/scene4d.json and
// OUT/scene4d.bin (src/gs/scene4d.h), OUT/trajectories.json and
// OUT/colmap/.
ExportSummary RunExport(const Workspace& workspace,
                        const ExportOptions& options);

}  // namespace pano4d
