// pano4d inspect PATH: what pano4d reads from a file, printed as JSON
// (src/pipeline/inspect.h).
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/pipeline/inspect.h"

namespace pano4d::cli {
namespace {

struct InspectOptions {
  std::string path;
  std::string as = "auto";
  bool count_frames = false;
};

}  // namespace

void AddInspectCommand(CLI::App& app, Action* action) {
  auto options = std::make_shared<InspectOptions>();
  CLI::App* sub = app.add_subcommand(
      "inspect",
      "Read an image, video or camera JSON as the pipeline would and print "
      "what it holds "
      "(JSON on stdout); a bad file gives the pipeline's error");
  sub->add_option("path", options->path, "File to read")->required();
  sub->add_option("--as", options->as,
                  "What the file is, when the extension does not say")
      ->check(CLI::IsMember({"auto", "image", "video", "camera", "json"}))
      ->capture_default_str();
  sub->add_flag(
      "--count-frames", options->count_frames,
      "Decode a whole video to count its frames (containers may misreport)");
  sub->callback([action, options] {
    *action = [options] {
      std::cout
          << Inspect(options->path, options->as, options->count_frames).dump(2)
          << "\n";
      return kExitOk;
    };
  });
}

}  // namespace pano4d::cli
