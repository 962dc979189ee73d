#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "src/core/timer.h"

namespace pano4d {

// Error against run time, for every long stage: one CSV row per record,
//   stage,iteration,wall_s,cpu_s,<column>...
// flushed as it is written, so a killed run keeps what it measured. Values
// are typically losses and validation PSNR / mPSNR / uPSNR; a value that is
// not there is an empty cell.
class RunRecorder {
 public:
  // Creates `csv` with a header, or with `resume` appends to an existing one
  // (same columns required) and continues its clocks from its last row, so
  // that a resumed run plots as one timeline.
  RunRecorder(const std::filesystem::path& csv, std::string stage,
              std::vector<std::string> columns, bool resume = false);

  // One row at the current wall and CPU time. `values` has one entry per
  // column. A NaN or infinite value is written as an empty cell and logged
  // as a warning naming the stage, column and iteration: it must not pass
  // unnoticed, nor stop the run that reports it.
  void Record(std::int64_t iteration,
              const std::vector<std::optional<double>>& values);

  const std::vector<std::string>& columns() const { return columns_; }
  double WallSeconds() const { return wall_offset_ + timer_.WallSeconds(); }

 private:
  std::filesystem::path path_;
  std::string stage_;
  std::vector<std::string> columns_;
  std::ofstream out_;
  Timer timer_;
  double wall_offset_ = 0.0;
  double cpu_offset_ = 0.0;
};

// A recorder's CSV read back: the columns after stage and iteration
// (wall_s, cpu_s, ...), one row per record; empty cells are nullopt.
struct RunLog {
  std::vector<std::string> stages;
  std::vector<std::int64_t> iterations;
  std::vector<std::string> columns;  // "wall_s", "cpu_s", then the values
  std::vector<std::vector<std::optional<double>>> rows;
};
RunLog ReadRunLog(const std::filesystem::path& csv);

}  // namespace pano4d
