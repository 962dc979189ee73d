// pano4d plot: a run log (error against run time) as a PNG.
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "evaluation/plot.h"
#include "src/cli/app.h"

namespace pano4d::cli {
namespace {

struct PlotCommandOptions {
  std::string csv;
  std::string out;
  std::vector<std::string> columns;
  std::string title;
};

int RunPlot(const PlotCommandOptions& options) {
  PlotRunLog(options.csv, options.out, options.columns, options.title);
  std::cout << "pano4d plot: " << options.out << "\n";
  return kExitOk;
}

}  // namespace

void AddPlotCommand(CLI::App& app, Action* action) {
  auto options = std::make_shared<PlotCommandOptions>();
  CLI::App* sub = app.add_subcommand("plot",
                                     "Plot a run log (error against run time, "
                                     "as every long stage writes) to a PNG");
  sub->add_option("--csv", options->csv,
                  "Run log: stage,iteration,wall_s,cpu_s,<columns>...")
      ->required();
  sub->add_option("--out", options->out, "PNG to write")->required();
  sub->add_option(
         "--columns", options->columns,
         "Columns to plot against wall time (default: all value columns)")
      ->delimiter(',');
  sub->add_option("--title", options->title, "Plot title (default: the stage)");
  sub->callback(
      [action, options] { *action = [options] { return RunPlot(*options); }; });
}

}  // namespace pano4d::cli
