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

struct FrameMetrics {
  std::string id;
  int camera_id = 0;
  int time_id = 0;
  double covisible_fraction = -1.0;  // of the frame's pixels; -1 without a mask
  MetricRow values;
};

struct EvaluationResult {
  std::string dataset;  // root folder
  std::string kind;
  std::string split;
  int factor = kEvaluationFactor;
  std::vector<FrameMetrics> frames;
  MetricRow mean;                              // plain mean over defined frames
  std::array<int, kNumMetrics> frames_used{};  // frames each mean is over
  std::vector<std::string> notes;              // why a column is unavailable
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

// Writes per_frame.csv, metrics.json and metrics.md into `out` (atomically)
// and returns the Markdown. Its table puts the paper's rows from
// `datasets_meta` (the benchmark file for the dataset's kind) beside
// pano4d's, when present.
std::string WriteEvaluation(const EvaluationResult& result,
                            const std::filesystem::path& out,
                            const std::filesystem::path& datasets_meta);

nlohmann::json EvaluationJson(const EvaluationResult& result);
std::string EvaluationMarkdown(const EvaluationResult& result,
                               const nlohmann::json& paper);
std::string EvaluationCsv(const EvaluationResult& result);

}  // namespace pano4d
