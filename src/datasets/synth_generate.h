#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/datasets/synth_cameras.h"

namespace pano4d::synth {

// Sizes at 1x; the 2x folders hold half of it, and evaluation uses 2x.
struct Preset {
  std::string name;
  int width;
  int height;
  int train_frames;
  int val_frames;  // per validation camera, at the first val_frames times
};
const std::vector<Preset>& Presets();  // tiny, small, medium
// Throws pano4d::Error listing the valid names.
const Preset& GetPreset(const std::string& name);

struct SynthOptions {
  std::string preset = "small";
  std::uint32_t seed = 0;
  bool is_static = false;
  double dynamic_scale = 1.0;  // see BuildScene; > 0
  // Draw the cameras' layout, sizes, texture scale and a near object from
  // the seed (VariedLayout, synth_scene.h) instead of the built-in scene's.
  bool varied = false;
  // How the training camera moves (synth_cameras.h): the arc, or a case
  // SfM finds hard (slow arc, pan, static camera).
  TrainingMotion trajectory = TrainingMotion::kArc;
  // Also write learned-like priors of the training frames (synth_priors.h):
  // disparity in disp/, flow in raft_exhaustive/.
  bool priors = false;
};

// What was generated. Written to synth.json without the timings, so the
// same options give the same bytes; the timings are only reported.
struct SynthSummary {
  Preset preset;
  std::uint32_t seed = 0;
  bool is_static = false;
  double dynamic_scale = 1.0;
  bool varied = false;
  TrainingMotion trajectory = TrainingMotion::kArc;
  bool priors = false;
  nlohmann::json layout;           // Layout::ToJson of a varied scene
  std::int64_t val_pixels = 0;     // 2x validation pixels with a surface
  std::int64_t unseen_pixels = 0;  // of those, not covisible
  double unseen_fraction = 0.0;
  int covisibility_threshold = 0;
  double render_seconds = 0.0;
  double covisibility_seconds = 0.0;
  double write_seconds = 0.0;

  nlohmann::json ToJson() const;  // without timings
};

// Renders the scene into `out` in the DyCheck iPhone layout, plus pano4d's
// ground-truth extras: depth for every frame, instance/{1x,2x} and
// dynamic/{1x,2x} masks, and synth.json (written last: a folder without it
// is incomplete). Shows a progress bar on stderr.
SynthSummary GenerateSynthScene(const SynthOptions& options,
                                const std::filesystem::path& out);

// Generates the scene in `out` unless an earlier run did (its synth.json
// is there); returns whether it generated. An earlier scene of another
// preset, seed or kind is a pano4d::Error naming its synth.json.
bool EnsureSynthScene(const SynthOptions& options,
                      const std::filesystem::path& out);

}  // namespace pano4d::synth
