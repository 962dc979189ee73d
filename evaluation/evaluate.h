#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "src/datasets/dataset.h"

namespace pano4d {

// The metric keys, in the paper's column order, then the strict SSIM
// variants. These are the JSON keys scripts read.
inline constexpr std::array<const char*, 11> kMetricKeys = {
    "psnr",  "ssim",  "lpips",  "mpsnr",        "mssim",       "mlpips",
    "upsnr", "ussim", "ulpips", "mssim_strict", "ussim_strict"};
inline constexpr std::size_t kNumMetrics = kMetricKeys.size();

// One value per key; nullopt where a value is unavailable (no covisible
// mask, an empty mask in this frame, no LPIPS weights).
using MetricRow = std::array<std::optional<double>, kNumMetrics>;

// A row as JSON, keyed by kMetricKeys: null where a value is unavailable or
// not finite (PSNR of identical images is +inf, which JSON cannot hold); and
// back (numbers only; other keys ignored).
nlohmann::json MetricRowJson(const MetricRow& row);
MetricRow MetricRowFromJson(const nlohmann::json& object);
// printf format of a metric's table cell: 2 decimals for PSNR, 3 otherwise.
const char* MetricFormat(std::size_t key);

struct FrameMetrics {
  std::string id;
  int camera_id = 0;
  int time_id = 0;
  double covisible_fraction = -1.0;  // of the frame's pixels; -1 without a mask
  MetricRow values;
};

// The floor every method must clear on the pixels no training frame saw:
// each evaluated frame painted with one colour, the mean over every pixel
// of the training frames, and scored as a render (no LPIPS). A method
// whose uPSNR is below it paints those pixels worse than a constant.
struct MeanColourFloor {
  std::array<double, 3> rgb{};  // in [0, 1]
  MetricRow mean;
};

struct EvaluationResult {
  std::string dataset;   // root folder
  std::string scene;     // Dataset::scene
  std::string protocol;  // SplitDescription: the splits and size that ran
  std::string kind;
  std::string split;
  int factor = kEvaluationFactor;
  std::vector<FrameMetrics> frames;
  MetricRow mean;                              // plain mean over defined frames
  std::array<int, kNumMetrics> frames_used{};  // frames each mean is over
  std::vector<std::string> notes;              // why a column is unavailable
  // Absent when the dataset has no training frames to take a colour from.
  std::optional<MeanColourFloor> floor;
};

struct EvaluateOptions {
  std::string split = "val";            // "val" or "train"
  std::filesystem::path lpips_weights;  // empty: LPIPS unavailable
};

// Scores the renders in `renders` (one image per frame, named <id>.png, or
// .jpg) against the dataset's frames of the split, as DyCheck does:
// quantised to 8 bits, per frame, then a plain mean. m* use the covisible
// mask, u* its complement. A missing render, a size mismatch or a NaN pixel
// is an error naming the file.
EvaluationResult EvaluateRenders(const Dataset& dataset,
                                 const std::filesystem::path& renders,
                                 const EvaluateOptions& options);

// A published result to set beside pano4d's: one method on one scene (from
// a benchmark file's per_scene_published), or the mean over a benchmark's
// scenes (the paper's table, or a source's mean row).
struct PublishedRow {
  std::string method;
  std::string source;  // "paper" or the per-scene source's short name
  bool mean = false;   // a mean over the benchmark's scenes
  MetricRow values;
};

// The benchmark file of datasets_meta/ for a dataset kind ("dycheck",
// "nvidia", "kubric4d"); null when there is none.
nlohmann::json BenchmarkMeta(const std::filesystem::path& datasets_meta,
                             const std::string& kind);

// The published rows for `scene` (matched case-insensitively on letters
// and digits: a folder "nvidia-balloon1" is scene "Balloon1"), then the
// means: each per-scene source's mean row and the paper's table.
std::vector<PublishedRow> PublishedRows(const nlohmann::json& benchmark,
                                        const std::string& scene);

// Writes per_frame.csv, metrics.json and metrics.md into `out` (atomically)
// and returns the Markdown. Its tables put the published rows of the
// benchmark file in `datasets_meta` beside pano4d's: this scene's rows in
// one table, the means over a benchmark's scenes in another.
std::string WriteEvaluation(const EvaluationResult& result,
                            const std::filesystem::path& out,
                            const std::filesystem::path& datasets_meta);

nlohmann::json EvaluationJson(const EvaluationResult& result);
std::string EvaluationMarkdown(const EvaluationResult& result,
                               const std::vector<PublishedRow>& published,
                               bool benchmark_known);
std::string EvaluationCsv(const EvaluationResult& result);

}  // namespace pano4d
