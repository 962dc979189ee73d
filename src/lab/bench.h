#pragma once

// `pano4d bench`: speed and accuracy tables, each a list of rows (JSON, as
// --json prints them) and the same rows as a table for people.
//   camera     every camera model: round-trip error against ns per call
//   render     the rasterizer: forward and forward+backward ms, on random
//              scenes or a fitted workspace's Gaussians at its cameras
//   stability  the stiff and extreme suite: non-finite values per case
//   budget     error against run time across fit budgets and resolutions
//   datasets   every scene of a benchmark root through `pano4d run --eval`,
//              beside the published rows

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "evaluation/evaluate.h"
#include "src/core/subprocess.h"

namespace pano4d {

struct BenchResult {
  std::vector<nlohmann::json> rows;
  std::string table;  // the rows for people, with a heading
};

struct BenchCameraOptions {
  int grid = 64;  // samples along x; y gets 3/4 of it
  double min_seconds = 0.2;
};
BenchResult RunBenchCamera(const BenchCameraOptions& options);

struct BenchRenderOptions {
  std::filesystem::path workspace;  // a fitted scene instead of random ones
  std::vector<int> gaussians = {10000, 100000, 500000};
  std::vector<std::string> sizes = {"480x360", "960x720"};  // WxH
  int repeats = 10;  // timed runs per case; the median is reported
};
BenchResult RunBenchRender(const BenchRenderOptions& options);

struct StabilityOptions {
  int fit_iterations = 300;  // of the short fits on the tiny scene
};
struct StabilityResult {
  BenchResult bench;            // one row per case
  std::int64_t non_finite = 0;  // over every case; must be 0
};
StabilityResult RunBenchStability(const StabilityOptions& options);

struct BudgetOptions {
  std::filesystem::path workspace = "pano4d_budget";
  std::string preset = "small";
  std::vector<int> iterations = {1000, 2000, 5000, 10000};
  // DyCheck evaluates at 2x (its covisibility masks exist only there); 1x
  // is the full resolution, scored by PSNR alone.
  std::vector<int> factors = {2, 1};
  bool expand = true;
};
// Writes WS/budget.md, WS/budget_<factor>x.csv and .png; each fit in its
// own workspace, read back when an earlier run finished it.
BenchResult RunBenchBudget(const BudgetOptions& options);

struct BenchDatasetsOptions {
  std::filesystem::path root;  // one scene folder per entry
  // nvidia, dycheck, kubric or synth (pano4d synth's scenes); empty: all.
  std::string suite;
  std::vector<std::string> scenes;  // folder names; empty: every scene found
  int iterations = 0;               // 0: run's default
  std::filesystem::path lpips_weights;  // empty: LPIPS reads n/a
  // Learned priors per scene: priors/<scene>/ (BenchRunCommand); empty:
  // none.
  std::filesystem::path priors;
  std::filesystem::path workspace = "pano4d_bench_datasets";  // WS/<scene>
  std::filesystem::path executable;  // pano4d; empty: this process's binary
};
// Runs `pano4d run --dataset <scene> --eval` per scene, each as a child
// process (its own workspace WS/<scene>, its log, its peak memory), at the
// factor of the scene's protocol (Kubric-4D 1, the others 2). A scene whose
// entry (WS/<scene>/pano4d/bench_entry.json) says it finished with the same
// command is read back, not run; a failed scene is a row with its error and
// the sweep goes on. Writes WS/datasets.md and WS/datasets.csv.
BenchResult RunBenchDatasets(const BenchDatasetsOptions& options);

// The benchmark suite a scene folder belongs to ("nvidia", "dycheck",
// "kubric", "synth"), or empty when it is no dataset pano4d reads.
std::string SuiteOf(const std::filesystem::path& scene);

inline const std::vector<std::string> kBenchSuites = {"nvidia", "dycheck",
                                                      "kubric", "synth"};

// A scene folder of a benchmark root and its suite.
struct BenchScene {
  std::filesystem::path dir;
  std::string suite;
  std::string name() const { return dir.filename().string(); }
};

// The scene folders of `root` (by name) of `suite` (empty: every suite)
// and, when `names` is not empty, only those. Throws pano4d::Error naming
// the root for an unknown suite, a name without its folder, or no scene.
std::vector<BenchScene> FindBenchScenes(const std::filesystem::path& root,
                                        const std::string& suite,
                                        const std::vector<std::string>& names);

// `EXE run --dataset SCENE --workspace WS --eval --factor F
// [--iterations N | --converge-on train] [--lpips-weights W] [--priors P]`,
// at the scene's protocol factor (Kubric-4D 1, the others 2), paths
// absolute; without N the convergence stop reads the training frames, so
// that the frames a table scores never choose where a fit ends; P is
// priors_root/<scene> when that folder holds learned priors (a root of
// scene folders that carry their own priors may be the data root itself).
// Throws pano4d::Error when the scene cannot be read.
std::vector<std::string> BenchRunCommand(
    const std::filesystem::path& executable, const BenchScene& scene,
    const std::filesystem::path& workspace, int iterations,
    const std::filesystem::path& lpips_weights,
    const std::filesystem::path& priors_root = {});

// bench datasets' table, which sweep collect writes too: its head, a
// metric's cell ("-" without a value), a row (the nine metric columns,
// seconds and peak memory as given), and the benchmark file of a suite
// whose published rows go beside it (null for synth, which has none).
inline constexpr std::size_t kBenchTableMetrics = 9;
inline constexpr const char* kBenchTableHead =
    "| Scene | Suite | Method | PSNR | SSIM | LPIPS | mPSNR | mSSIM | "
    "mLPIPS | uPSNR | uSSIM | uLPIPS | Seconds | Peak MiB |\n"
    "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
std::string BenchCell(const std::optional<double>& value, std::size_t key);
std::string BenchMarkdownRow(const std::string& scene, const std::string& suite,
                             const std::string& method, const MetricRow& values,
                             const std::string& seconds,
                             const std::string& memory);
nlohmann::json SuiteBenchmarkMeta(const std::string& suite);

}  // namespace pano4d
