#include "src/core/run_recorder.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/log.h"

namespace pano4d {
namespace {

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream stream(line);
  std::string cell;
  while (std::getline(stream, cell, ',')) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

std::optional<double> ParseCell(const std::string& cell,
                                const std::string& source,
                                const std::string& column) {
  if (cell.empty()) return std::nullopt;
  char* end = nullptr;
  const double value = std::strtod(cell.c_str(), &end);
  if (end != cell.c_str() + cell.size() || !std::isfinite(value)) {
    throw Error(source, column, "\"" + cell + "\"",
                "expected a finite number or an empty cell");
  }
  return value;
}

std::string Header(const std::vector<std::string>& columns) {
  std::string header = "stage,iteration,wall_s,cpu_s";
  for (const std::string& c : columns) header += "," + c;
  return header;
}

}  // namespace

RunRecorder::RunRecorder(const std::filesystem::path& csv, std::string stage,
                         std::vector<std::string> columns, bool resume)
    : path_(csv), stage_(std::move(stage)), columns_(std::move(columns)) {
  for (const std::string& c : columns_) {
    if (c.empty() || c.find(',') != std::string::npos ||
        c.find('\n') != std::string::npos) {
      throw Error(csv.string(), "column", "\"" + c + "\"",
                  "column names must be non-empty, no commas");
    }
  }
  if (csv.has_parent_path()) EnsureDirectory(csv.parent_path());
  if (resume && std::filesystem::exists(csv)) {
    const RunLog log = ReadRunLog(csv);
    std::vector<std::string> expected = {"wall_s", "cpu_s"};
    expected.insert(expected.end(), columns_.begin(), columns_.end());
    if (log.columns != expected) {
      throw Error(csv.string(), "header", "",
                  "cannot resume: the file has other columns");
    }
    if (!log.rows.empty()) {
      wall_offset_ = log.rows.back()[0].value_or(0.0);
      cpu_offset_ = log.rows.back()[1].value_or(0.0);
    }
    out_.open(csv, std::ios::app);
  } else {
    out_.open(csv, std::ios::trunc);
    out_ << Header(columns_) << "\n" << std::flush;
  }
  if (!out_)
    throw Error::In(csv.string(), "cannot open the run log for writing");
}

void RunRecorder::Record(std::int64_t iteration,
                         const std::vector<std::optional<double>>& values) {
  if (values.size() != columns_.size()) {
    throw Error(path_.string(), "values", std::to_string(values.size()),
                "expected one value per column (" +
                    std::to_string(columns_.size()) + ")");
  }
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.3f,%.3f", WallSeconds(),
                cpu_offset_ + timer_.CpuSeconds());
  out_ << stage_ << "," << iteration << "," << buffer;
  for (std::size_t i = 0; i < values.size(); ++i) {
    out_ << ",";
    if (!values[i]) continue;
    if (!std::isfinite(*values[i])) {
      PANO4D_LOG(kWarning) << stage_ << ": " << columns_[i] << " is "
                           << *values[i] << " at iteration " << iteration
                           << " (written as an empty cell in " << path_.string()
                           << ")";
      continue;
    }
    std::snprintf(buffer, sizeof(buffer), "%.9g", *values[i]);
    out_ << buffer;
  }
  out_ << "\n" << std::flush;
  if (!out_) throw Error::In(path_.string(), "write failed");
}

RunLog ReadRunLog(const std::filesystem::path& csv) {
  std::istringstream in(ReadTextFile(csv));
  std::string line;
  if (!std::getline(in, line))
    throw Error::In(csv.string(), "is empty, expected a run log");
  const std::vector<std::string> header = SplitCsv(line);
  if (header.size() < 4 || header[0] != "stage" || header[1] != "iteration" ||
      header[2] != "wall_s" || header[3] != "cpu_s") {
    throw Error(csv.string(), "header", "\"" + line + "\"",
                "expected stage,iteration,wall_s,cpu_s,... (a pano4d run log)");
  }
  RunLog log;
  log.columns.assign(header.begin() + 2, header.end());
  int line_number = 1;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty()) continue;
    const std::vector<std::string> cells = SplitCsv(line);
    const std::string where =
        csv.string() + " line " + std::to_string(line_number);
    if (cells.size() != header.size()) {
      throw Error(
          where, "cells", std::to_string(cells.size()),
          "expected " + std::to_string(header.size()) + " like the header");
    }
    log.stages.push_back(cells[0]);
    const std::optional<double> iteration =
        ParseCell(cells[1], where, "iteration");
    log.iterations.push_back(iteration ? static_cast<std::int64_t>(*iteration)
                                       : 0);
    std::vector<std::optional<double>> row;
    for (std::size_t i = 2; i < cells.size(); ++i)
      row.push_back(ParseCell(cells[i], where, header[i]));
    log.rows.push_back(std::move(row));
  }
  return log;
}

}  // namespace pano4d
