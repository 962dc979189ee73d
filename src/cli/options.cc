#include "src/cli/options.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <optional>

#include <CLI/CLI.hpp>

#include "src/core/strings.h"

namespace pano4d::cli {
namespace {

// A number in `text` (all of it), or nullopt.
std::optional<double> ParseNumber(const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size()) return std::nullopt;
  return v;
}

// A bound as a person writes it: 0, 0.5, 65535, 1e+06.
std::string BoundText(double v) { return StringPrintf("%g", v); }

CLI::Validator NumberCheck(std::function<bool(double)> ok,
                           const std::string& what, const std::string& name) {
  return CLI::Validator(
      [ok, what](const std::string& text) -> std::string {
        const std::optional<double> v = ParseNumber(text);
        if (!v || !std::isfinite(*v) || !ok(*v))
          return "must be " + what + ", not " + text;
        return {};
      },
      name, name);
}

}  // namespace

CLI::Validator NonNegative() {
  return NumberCheck([](double v) { return v >= 0; }, "a number >= 0",
                     "NONNEGATIVE");
}

CLI::Validator Positive() {
  return NumberCheck([](double v) { return v > 0; }, "a number > 0",
                     "POSITIVE");
}

CLI::Validator InRange(double lo, double hi) {
  return NumberCheck([lo, hi](double v) { return v >= lo && v <= hi; },
                     "a number from " + BoundText(lo) + " to " + BoundText(hi),
                     "[" + BoundText(lo) + ", " + BoundText(hi) + "]");
}

void RefuseNonFiniteAndEmptyValues(CLI::App* app) {
  const CLI::Validator finite =
      NumberCheck([](double) { return true; }, "a finite number", "");
  const CLI::Validator not_empty(
      [](const std::string& text) -> std::string {
        return text.empty() ? "must not be empty" : "";
      },
      "", "");
  for (CLI::Option* o : app->get_options()) {
    if (o->get_expected_max() == 0) continue;  // a flag
    if (o->get_type_name().rfind("FLOAT", 0) == 0) o->check(finite);
    if (o->get_type_name().rfind("TEXT", 0) == 0) o->check(not_empty);
  }
  for (CLI::App* sub : app->get_subcommands({}))
    RefuseNonFiniteAndEmptyValues(sub);
}

void AddTrainerOptions(CLI::App* app, TrainerOptions* o) {
  app->add_option("--max-gaussians", o->strategy.max_gaussians,
                  "Densification stops adding Gaussians at this count")
      ->capture_default_str();
  app->add_option("--smoothness-weight", o->smoothness_weight,
                  "Weight of the motion bases' acceleration penalty")
      ->capture_default_str();
  app->add_option("--normal-weight", o->normal_weight,
                  "Weight of the depth-normal flatness term: Gaussians on a "
                  "surface the depth maps show become discs in it (0: off)")
      ->capture_default_str();
  app->add_option("--hidden-weight", o->hidden_weight,
                  "Weight of the hidden-depth term: a moving object's "
                  "Gaussians may not hide deeper behind its visible surface "
                  "than --hidden-thickness (0: off)")
      ->capture_default_str();
  app->add_option("--hidden-thickness", o->hidden_thickness,
                  "Thickness of moving objects, relative to their depth, "
                  "for the hidden-depth term")
      ->capture_default_str();
  app->add_option("--flow-weight", o->flow_weight,
                  "Weight of the flow loss on views with learned flow "
                  "(--priors): a moving Gaussian posed at a neighbouring "
                  "frame's time lands where the flow carries its pixel (0: "
                  "off)")
      ->check(NonNegative())
      ->capture_default_str();
  app->add_option("--disparity-weight", o->disparity_weight,
                  "Weight of the scale- and shift-invariant loss of the "
                  "rendered inverse depth against learned disparity "
                  "(--priors; 0: off)")
      ->check(NonNegative())
      ->capture_default_str();
  app->add_flag("--disparity-moving-only,!--disparity-everywhere",
                o->disparity_moving_only,
                "The disparity term on the moving pixels only, leaving the "
                "static ones to stereo (default: every pixel)");
  app->add_flag(
      "--no-appearance", [o](std::int64_t) { o->appearance = false; },
      "No per-frame colour transform: the Gaussians' colours explain every "
      "frame's exposure and white balance as they are");
  app->add_option("--appearance-weight", o->appearance_weight,
                  "How strongly each frame's affine colour transform is held "
                  "near the identity")
      ->check(NonNegative())
      ->capture_default_str();
  app->add_option("--max-static-scale-pixels", o->max_static_scale_pixels,
                  "Largest scale of a static Gaussian, in pixels at the "
                  "median depth; clamped after every step (0: no clamp)")
      ->capture_default_str();
}

void AddInitOptions(CLI::App* app, InitOptions* o) {
  app->add_option("--num-bases", o->num_bases,
                  "Motion bases K for dynamic content (0: every Gaussian "
                  "static)")
      ->check(NonNegative())
      ->capture_default_str();
  app->add_flag(
      "--no-motion", [o](std::int64_t) { o->num_bases = 0; },
      "Fit every Gaussian as static (no motion bases: --num-bases 0)");
  app->add_option("--dynamic-thickness", o->dynamic_thickness,
                  "Moving objects start solid: each moving pixel of the "
                  "canonical frame also seeds Gaussians behind it, out to "
                  "this times the depth a round cross-section of its mask's "
                  "local width has there (0: the visible surface only)")
      ->capture_default_str();
  app->add_option("--dynamic-layers", o->dynamic_layers,
                  "Gaussians seeded behind each such pixel")
      ->capture_default_str();
  app->add_option("--sh-degree", o->sh_degree,
                  "Spherical-harmonics degree of the colours (0-3)")
      ->capture_default_str();
}

void AddExpansionOptions(CLI::App* app, ExpansionOptions* o) {
  app->add_option("--directions", o->geometry.directions,
                  "Expansion directions M")
      ->capture_default_str();
  app->add_option("--expansion-steps", o->geometry.steps, "Expansion steps E")
      ->capture_default_str();
  app->add_option("--alpha", o->geometry.alpha_degrees,
                  "Angle per expansion step, degrees")
      ->capture_default_str();
  app->add_flag("--planar-expansion", o->geometry.planar,
                "Ablation: translate cameras in the image plane instead of "
                "orbiting them on the panorama");
  app->add_option("--expand-every", o->every,
                  "An expansion every N fit iterations; the steps are "
                  "spread over them")
      ->capture_default_str();
  app->add_option("--expansion-stride", o->time_stride,
                  "Expand every N-th training frame in time")
      ->capture_default_str();
  app->add_option("--refine-weight", o->refine_weight,
                  "Weight of L_refine on the expanded views")
      ->capture_default_str();
  app->add_option("--refine-outside-weight", o->refine_outside_weight,
                  "L_refine's weight on the warped pixels outside M_e, "
                  "relative to those in it; 0: the paper's loss, masked to "
                  "M_e (the Gaussians that fill M_e may then spread over "
                  "the warped content)")
      ->check(NonNegative())
      ->capture_default_str();
  app->add_option("--refine-every", o->refine_every,
                  "L_refine on one expanded view every N iterations")
      ->capture_default_str();
  app->add_option("--carve-every", o->carve_every,
                  "Every N iterations once an expansion step has run (and at "
                  "every step), remove the static Gaussians in known empty "
                  "space: seen through by a training frame, or seen by none "
                  "and seen through by an expanded view's warp or by most "
                  "expanded views; 0: only at the steps")
      ->check(NonNegative())
      ->capture_default_str();
  app->add_flag("--one-step-expansion", o->one_step,
                "Ablation: no progressive expansion, one step at the full "
                "angle E x alpha");
  app->add_flag(
      "--no-gaussian-refinement",
      [o](std::int64_t) { o->gaussian_refinement = false; },
      "Ablation (panorama results only): expanded views are made and "
      "written but not distilled into the Gaussians, which serve as geometry; "
      "the validation views are warped from the training frames and the "
      "refined expanded views, the rest filled by the prior");
}

void AddExpansionProductOptions(CLI::App* app, FitOptions* o) {
  app->add_option_function<std::string>(
         "--warp-depth",
         [o](const std::string& v) {
           o->warp_depth =
               v == "given" ? WarpDepth::kGiven : WarpDepth::kRendered;
         },
         "The depth the source frames are warped with: given (each frame's "
         "depth map, rendered depth where it has none) or rendered (from "
         "the Gaussians, the paper's); default: given on depth the dataset "
         "gives, rendered on estimated depth")
      ->check(CLI::IsMember({"given", "rendered"}));
  app->add_option("--prior-cmd", o->prior_cmd,
                  "External video prior: a command with {in} and {out} "
                  "(folders; see README). Without it, the CPU geometry prior. "
                  "When the command fails, the CPU prior fills in and the log "
                  "says why");
  app->add_option("--prior-timeout", o->prior_timeout,
                  "Seconds one clip may take in --prior-cmd before the "
                  "command (and all it started) is stopped and the CPU prior "
                  "fills the clip; a video diffusion model on a GPU takes "
                  "minutes per clip")
      ->check(Positive())
      ->capture_default_str();
  app->add_option("--panorama-width", o->panorama_width,
                  "Width of the panoramas in WS/pano4d/panorama (height half)")
      ->check(InRange(2, 16384))
      ->capture_default_str();
}

void AddNoExpansionFlag(CLI::App* app, bool* expand) {
  app->add_flag(
      "--no-expansion", [expand](std::int64_t) { *expand = false; },
      "The same fit without panoramic expansion (the baseline of every "
      "ablation)");
}

namespace {

// Unsigned parsing accepts "-1" and wraps it, and saturates a value past
// the type's largest; a seed must be exactly the number given.
template <typename Seed>
CLI::Validator SeedCheck() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        const auto first = value.find_first_not_of(" \t");
        const std::string bad =
            "a seed is a non-negative integer up to " +
            std::to_string(std::numeric_limits<Seed>::max()) + ", not " + value;
        if (first == std::string::npos || value[first] == '-') return bad;
        errno = 0;
        char* end = nullptr;
        const unsigned long long v =
            std::strtoull(value.c_str() + first, &end, 10);
        if (errno == ERANGE || *end != '\0' ||
            v > std::numeric_limits<Seed>::max())
          return bad;
        return "";
      },
      "SEED");
}

template <typename Seed>
CLI::Option* AddUnsignedSeed(CLI::App* app, Seed* seed,
                             const std::string& help) {
  return app->add_option("--seed", *seed, help)
      ->check(SeedCheck<Seed>())
      ->capture_default_str();
}

}  // namespace

CLI::Option* AddSeedOption(CLI::App* app, std::uint64_t* seed,
                           const std::string& help) {
  return AddUnsignedSeed(app, seed, help);
}

CLI::Option* AddSeedOption(CLI::App* app, std::uint32_t* seed,
                           const std::string& help) {
  return AddUnsignedSeed(app, seed, help);
}

void AddFitOptions(CLI::App* app, FitOptions* o) {
  AddSeedOption(app, &o->seed, "Seed of every random choice");
  app->add_option_function<int>(
         "--iterations", [o](int n) { o->iterations = n; },
         "Training iterations (default: 100 per training frame, 2000 to "
         "10000, ended earlier by the convergence stop; a number given here "
         "runs to its end unless --converge-on is given too)")
      ->check(Positive());
  app->add_option_function<std::string>(
         "--converge-on",
         [o](const std::string& s) { o->converge_on = ParseConvergeOn(s); },
         "The convergence stop's signal: val (the validation frames' PSNR; "
         "the stopping iteration is then chosen on them), train (every "
         "training frame's PSNR), auto (val when there are validation "
         "frames, else train; the default unless --iterations is given) or "
         "off. It samples every --converge-every iterations after the last "
         "expansion step and the end of densification, and stops when the "
         "last --converge-window iterations gained less than "
         "--converge-min-gain dB")
      ->check(CLI::IsMember({"auto", "val", "train", "off"}));
  app->add_option("--converge-every", o->convergence.every,
                  "Iterations between the convergence stop's samples")
      ->capture_default_str()
      ->check(Positive());
  app->add_option("--converge-window", o->convergence.window,
                  "Iterations over which the convergence stop measures the "
                  "gain (a multiple of --converge-every)")
      ->capture_default_str()
      ->check(Positive());
  app->add_option("--converge-min-gain", o->convergence.min_gain,
                  "The least gain (dB) over the window that keeps a fit going")
      ->capture_default_str()
      ->check(NonNegative());
  AddTrainerOptions(app, &o->trainer);
  app->add_option_function<double>(
         "--depth-weight", [o](double w) { o->depth_weight = w; },
         "Weight of the depth loss (default: 5 on depth the dataset gives, "
         "1 on estimated depth: stereo or --depth-dir)")
      ->check(NonNegative());
  AddInitOptions(app, &o->init);
  app->add_option_function<double>(
         "--voxel-pixels", [o](double v) { o->voxel_pixels = v; },
         "Voxel of the initial point cloud, in pixels at the median depth "
         "(default: 2 on depth the dataset gives, 4 on estimated depth, "
         "whose error would otherwise multiply one surface's points)")
      ->check(Positive());
  AddNoExpansionFlag(app, &o->expand);
  AddExpansionOptions(app, &o->expansion);
  AddExpansionProductOptions(app, o);
  app->add_flag("--deterministic", o->deterministic,
                "Guarantee that the result depends only on the inputs, "
                "options and seed: no wall-clock decision (refuses "
                "--time-budget). Results never depend on the thread count, "
                "and a resumed run equals an uninterrupted one");
  app->add_option("--checkpoint-every", o->checkpoint_every,
                  "Write the checkpoint every N iterations (atomically)")
      ->capture_default_str();
  app->add_option("--validate-every", o->validate_every,
                  "Validation PSNR/mPSNR/uPSNR into the run log every N "
                  "iterations")
      ->capture_default_str();
  app->add_option("--log-every", o->log_every,
                  "A run-log row (losses, Gaussians) every N iterations")
      ->capture_default_str();
  app->add_option("--time-budget", o->time_budget,
                  "Stop after this many seconds of wall time (0: no limit)")
      ->capture_default_str();
}

void AddFramesInputOptions(CLI::App* app, std::filesystem::path* video,
                           std::filesystem::path* images) {
  app->add_option("--video", *video,
                  "A video file (COLMAP estimates the poses)")
      ->check(CLI::ExistingFile);
  app->add_option("--images", *images,
                  "A folder of .png/.jpg frames, in name order (COLMAP "
                  "estimates the poses)")
      ->check(CLI::ExistingDirectory);
}

CLI::Option* AddDatasetOption(CLI::App* app, std::filesystem::path* dataset) {
  return app
      ->add_option("--dataset", *dataset,
                   "A dataset with known cameras: DyCheck iPhone (or pano4d "
                   "synth), Nvidia Dynamic Scenes or Kubric-4D; its cameras, "
                   "and its depth and validation frames where it has them")
      ->check(CLI::ExistingDirectory);
}

void AddFactorOption(CLI::App* app, int* factor) {
  app->add_option("--factor", *factor,
                  "Resolution divisor of a dataset's frames; 0: the "
                  "benchmark's protocol (2 for DyCheck and Nvidia, 1 for "
                  "Kubric-4D)")
      ->check(NonNegative())
      ->capture_default_str();
}

void AddLpipsWeightsOption(CLI::App* app, std::filesystem::path* weights) {
  app->add_option(
         "--lpips-weights", *weights,
         "Folder of LPIPS AlexNet v0.1 weights (.npy files; see "
         "scripts/lpips_weights_from_torch.py); without it LPIPS reads n/a")
      ->check(CLI::ExistingDirectory);
}

void AddDepthDirOption(CLI::App* app, std::filesystem::path* depth_dir) {
  app->add_option("--depth-dir", *depth_dir,
                  "Depth maps from another tool, <frame>.npy/.png (mm)/.tiff/"
                  ".exr: scale and shift fitted per frame to the SfM points "
                  "(Ceres, Cauchy loss); preferred to a dataset's own depth "
                  "and to stereo")
      ->check(CLI::ExistingDirectory);
}

void AddPriorsOptions(CLI::App* app, std::filesystem::path* priors,
                      DepthOptions* depth) {
  app->add_option("--priors", *priors,
                  "Learned priors as the tools wrote them (MiDaS / Depth "
                  "Anything / UniDepth disparity, metric depth, RAFT flow, "
                  "TAP / CoTracker tracks, motion masks in the layouts of "
                  "DynamicNeRF, OmniMotion, Shape of Motion and MoSca; any "
                  "resolution): depth for moving pixels and where stereo "
                  "has none, the motion's tracks, a flow loss; `pano4d "
                  "dataset info DIR` lists what a folder holds")
      ->check(CLI::ExistingDirectory);
  if (depth) {
    app->add_flag("--prior-masks-join", depth->prior_masks_join,
                  "Add the priors' motion masks to the computed ones instead "
                  "of replacing them");
    app->add_option("--learned-depth-smoothing", depth->learned_depth_smoothing,
                    "Correct the learned depth locally towards stereo: a "
                    "Gaussian of this fraction of the frame's width (0: one "
                    "affine per frame only)")
        ->check(InRange(0.0, 1.0))
        ->capture_default_str();
    app->add_flag("--consistent-moving-depth,!--no-consistent-moving-depth",
                  depth->consistent_moving_depth,
                  "Rescale each frame's moving pixels' learned depth so that "
                  "along the priors' flow it changes between neighbouring "
                  "frames as much as the flow stretches them (default; "
                  "needs flow)");
  }
}

void AddHoldoutOption(CLI::App* app, int* holdout) {
  app->add_option("--holdout", *holdout,
                  "Video or images: every N-th frame (i % N == 0) is held "
                  "out for validation PSNR (0: none)")
      ->capture_default_str();
}

void AddMaxSizeOption(CLI::App* app, int* max_size) {
  app->add_option("--max-size", *max_size,
                  "Video or images: resize the frames to this longest side "
                  "in pixels before SfM (0: as they are)")
      ->capture_default_str();
}

void AddPresetOption(CLI::App* app, std::string* preset) {
  app->add_option("--preset", *preset,
                  "Synthetic scene: tiny (128x96, 8 frames; tests), small "
                  "(480x360, 48 frames; demo), medium (960x720, 120 frames; "
                  "benchmarks)")
      ->check(CLI::IsMember({"tiny", "small", "medium"}))
      ->capture_default_str();
}

}  // namespace pano4d::cli
