#pragma once

// The flags of the pipeline's options structs, each registered by one
// function with one help text, shared by every command that exposes it
// (`fit`, `run` and `demo` all call AddFitOptions). A flag maps onto one
// field; its default is the field's, shown by --help.

#include <cstdint>
#include <filesystem>
#include <string>

#include "src/gs/init.h"
#include "src/gs/trainer.h"
#include "src/pano/expansion.h"
#include "src/pipeline/depth.h"
#include "src/pipeline/fit_options.h"

namespace CLI {
class App;
class Option;
class Validator;
}  // namespace CLI

namespace pano4d::cli {

// Option checks whose messages name the range readably ("must be a number
// >= 0, not -2") and which refuse NaN and Inf: CLI11's NonNegativeNumber
// prints its bound with 300 digits, and NaN passes every range test.
CLI::Validator NonNegative();
CLI::Validator Positive();
CLI::Validator InRange(double lo, double hi);
// Adds checks refusing NaN and Inf to every floating-point option of `app`
// and its subcommands, and an empty value to every text or path option (an
// empty path would otherwise reach the file system and be reported without
// a name). Main calls it once, after the commands are built.
void RefuseNonFiniteAndEmptyValues(CLI::App* app);

// --seed into an unsigned seed. A negative value is a usage error
// (unsigned parsing would wrap -1 to 18446744073709551615).
CLI::Option* AddSeedOption(CLI::App* app, std::uint64_t* seed,
                           const std::string& help);
CLI::Option* AddSeedOption(CLI::App* app, std::uint32_t* seed,
                           const std::string& help);

// --iterations, --max-gaussians and the loss weights (--smoothness-weight,
// --normal-weight, --hidden-weight, --hidden-thickness,
// --max-static-scale-pixels).
void AddTrainerOptions(CLI::App* app, TrainerOptions* options);

// --num-bases (--no-motion: 0), --dynamic-thickness, --dynamic-layers,
// --sh-degree.
void AddInitOptions(CLI::App* app, InitOptions* options);

// The geometry (--directions, --expansion-steps, --alpha,
// --planar-expansion), the schedule (--expand-every, --expansion-stride,
// --refine-every, --carve-every), L_refine (--refine-weight,
// --refine-outside-weight) and the ablations (--one-step-expansion,
// --no-gaussian-refinement).
void AddExpansionOptions(CLI::App* app, ExpansionOptions* options);

// What the expansion's products take from the fit's options: --warp-depth,
// --prior-cmd, --panorama-width.
void AddExpansionProductOptions(CLI::App* app, FitOptions* options);

// --no-expansion (FitOptions::expand = false).
void AddNoExpansionFlag(CLI::App* app, bool* expand);

// Everything a fit takes but --workspace and --resume: the above, --seed,
// --depth-weight, --deterministic, --checkpoint-every, --validate-every,
// --log-every, --time-budget.
void AddFitOptions(CLI::App* app, FitOptions* options);

// The frames of a capture without poses: --video (a file) and --images (a
// folder of .png/.jpg frames in name order), both checked to exist.
void AddFramesInputOptions(CLI::App* app, std::filesystem::path* video,
                           std::filesystem::path* images);
// --dataset: a folder in one of the layouts pano4d reads (DyCheck iPhone,
// Nvidia, Kubric-4D, pano4d synth), checked to exist. Returns the option
// (for ->required()).
CLI::Option* AddDatasetOption(CLI::App* app, std::filesystem::path* dataset);

// A dataset's resolution divisor (--factor).
void AddFactorOption(CLI::App* app, int* factor);
// Video or images: every N-th frame held out for validation (--holdout).
void AddHoldoutOption(CLI::App* app, int* holdout);
// --lpips-weights: the LPIPS AlexNet weights folder (LPIPS reads n/a
// without it).
void AddLpipsWeightsOption(CLI::App* app, std::filesystem::path* weights);
// --depth-dir: depth maps from another tool, aligned to the SfM points.
void AddDepthDirOption(CLI::App* app, std::filesystem::path* depth_dir);
// --priors: a folder of learned priors (src/datasets/priors.h); with
// `masks_join`, --prior-masks-join too (the depth stage's).
void AddPriorsOptions(CLI::App* app, std::filesystem::path* priors,
                      DepthOptions* depth = nullptr);
// Video or images: the longest side frames are resized to (--max-size).
void AddMaxSizeOption(CLI::App* app, int* max_size);
// The synthetic scene's preset (--preset tiny|small|medium).
void AddPresetOption(CLI::App* app, std::string* preset);

}  // namespace pano4d::cli
