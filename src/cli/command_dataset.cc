// pano4d dataset info DIR: what a dataset holds, as JSON on stdout.
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/json.h"
#include "src/core/error.h"
#include "src/datasets/dataset.h"
#include "src/datasets/priors.h"
#include "src/pipeline/priors.h"

namespace pano4d::cli {
namespace {

struct DatasetInfoOptions {
  std::string root;
  int factor = kProtocolFactor;
};

// A folder may be a dataset, a folder of learned priors, or both (a
// dataset shipped with its priors, as Balloon1): the JSON has the
// dataset's keys and, when it holds priors, "priors" (the layouts found
// and what a run does with each). Neither: the dataset loader's error and
// the priors' together.
int RunDatasetInfo(const DatasetInfoOptions& options) {
  nlohmann::json info = nlohmann::json::object();
  std::string dataset_error, priors_error;
  try {
    info = DatasetInfo(LoadDataset(options.root, options.factor));
  } catch (const Error& e) {
    dataset_error = e.what();
  }
  try {
    const PriorsFolder priors = ScanPriors(options.root);
    info["priors"] = priors.ToJson();
    info["priors"]["use"] = DescribePriorUse(priors);
  } catch (const Error& e) {
    priors_error = e.what();
  }
  if (!dataset_error.empty() && !priors_error.empty()) {
    throw Error(options.root, "", "",
                "neither a dataset nor a priors folder: " + dataset_error +
                    "; " + priors_error);
  }
  std::cout << info.dump(2) << "\n";
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
      "image sizes, and whether RGB, depth and covisible masks are present; "
      "for a folder of learned priors (--priors), the layouts it holds and "
      "what a run does with each");
  info->add_option("dir", options->root, "Dataset or priors folder")
      ->required();
  AddFactorOption(info, &options->factor);
  info->callback([action, options] {
    *action = [options] { return RunDatasetInfo(*options); };
  });
}

}  // namespace pano4d::cli
