// pano4d dataset info DIR: what a dataset holds, as JSON on stdout.
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/json.h"
#include "src/datasets/dataset.h"

namespace pano4d::cli {
namespace {

struct DatasetInfoOptions {
  std::string root;
  int factor = kProtocolFactor;
};

int RunDatasetInfo(const DatasetInfoOptions& options) {
  const Dataset dataset = LoadDataset(options.root, options.factor);
  std::cout << DatasetInfo(dataset).dump(2) << "\n";
  return kExitOk;
}

}  // namespace

void AddDatasetCommand(CLI::App& app, Action* action) {
  CLI::App* dataset = app.add_subcommand(
      "dataset", "Inspect a dataset (DyCheck iPhone layout, pano4d synthetic)");
  dataset->require_subcommand(1);
  auto options = std::make_shared<DatasetInfoOptions>();
  CLI::App* info = dataset->add_subcommand(
      "info",
      "Print as JSON: the kind of dataset, frame counts per split and camera, "
      "image sizes, "
      "and whether RGB, depth and covisible masks are present");
  info->add_option("dir", options->root, "Dataset folder")->required();
  AddFactorOption(info, &options->factor);
  info->callback([action, options] {
    *action = [options] { return RunDatasetInfo(*options); };
  });
}

}  // namespace pano4d::cli
