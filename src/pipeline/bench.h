#pragma once

// `pano4d bench`: speed and accuracy tables, each a list of rows (JSON, as
// --json prints them) and the same rows as a table for people.
//   camera     every camera model: round-trip error against ns per call
//   render     the rasterizer: forward and forward+backward ms, on random
//              scenes or a fitted workspace's Gaussians at its cameras
//   stability  the stiff and extreme suite: non-finite values per case
//   budget     error against run time across fit budgets and resolutions

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

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

}  // namespace pano4d
