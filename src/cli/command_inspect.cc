// pano4d inspect PATH: what pano4d reads from a file (image, video, camera
// JSON), printed as JSON. It reads through the same functions as the
// pipeline, so a file that inspect rejects is one the pipeline would reject,
// with the same message.
#include <algorithm>
#include <cctype>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <opencv2/core.hpp>

#include "src/cli/app.h"
#include "src/core/camera.h"
#include "src/core/camera_check.h"
#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/video.h"

namespace pano4d::cli {
namespace {

struct InspectOptions {
  std::string path;
  std::string as = "auto";
  bool count_frames = false;
};

std::string LowerExtension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

std::string GuessKind(const std::filesystem::path& path) {
  const std::string ext = LowerExtension(path);
  if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".exr")
    return "image";
  if (ext == ".json") return "json";
  if (ext == ".mp4" || ext == ".avi" || ext == ".mov" || ext == ".mkv" ||
      ext == ".webm" || ext == ".m4v") {
    return "video";
  }
  throw Error(
      path.string(), "extension", "\"" + path.extension().string() + "\"",
      "cannot tell what this file is; pass --as image|video|camera|json");
}

Json InspectImage(const std::filesystem::path& path) {
  cv::Mat alpha;
  const Image image = ReadImage(path, &alpha);
  cv::Scalar mean = cv::mean(image.mat());
  double min_value = 0, max_value = 0;
  cv::minMaxLoc(image.mat().reshape(1), &min_value, &max_value);
  return Json{{"kind", "image"},
              {"path", path.string()},
              {"width", image.width()},
              {"height", image.height()},
              {"has_alpha", !alpha.empty()},
              {"min", min_value},
              {"max", max_value},
              {"mean_rgb", {mean[0], mean[1], mean[2]}}};
}

Json InspectVideo(const std::filesystem::path& path, bool count_frames) {
  VideoReader reader(path);
  Json out{{"kind", "video"},
           {"path", path.string()},
           {"width", reader.info().width},
           {"height", reader.info().height},
           {"fps", reader.info().fps},
           {"frame_count_reported", reader.info().frame_count}};
  if (count_frames) {
    std::int64_t decoded = 0;
    Image frame;
    while (reader.Next(&frame)) ++decoded;
    out["frame_count_decoded"] = decoded;
  }
  return out;
}

Json InspectCamera(const Json& json, const std::string& source) {
  const Camera camera = CameraFromJson(json, source);
  // A coarse grid is enough to tell a usable model from a broken one.
  constexpr int kGridX = 32;
  constexpr int kGridY = 24;
  const RoundTripStats stats = MeasureRoundTrip(camera, kGridX, kGridY);
  Json out = CameraToJson(camera);
  out["kind"] = "camera";
  out["path"] = source;
  out["model_id"] = static_cast<int>(camera.model_id);
  out["params_info"] = std::string(camera.info().params_info);
  out["round_trip"] = Json{{"samples", stats.samples},
                           {"failures", stats.failures},
                           {"max_error_px", stats.max_error_px}};
  return out;
}

int RunInspect(const InspectOptions& options) {
  const std::filesystem::path path(options.path);
  const std::string kind = options.as == "auto" ? GuessKind(path) : options.as;
  Json out;
  if (kind == "image") {
    out = InspectImage(path);
  } else if (kind == "video") {
    out = InspectVideo(path, options.count_frames);
  } else {
    const Json json = ReadJson(path);
    if (kind == "camera" ||
        (kind == "json" && json.is_object() && json.contains("model"))) {
      out = InspectCamera(json, path.string());
    } else {
      Json keys = Json::array();
      if (json.is_object()) {
        for (const auto& item : json.items()) keys.push_back(item.key());
      }
      out = Json{{"kind", "json"},
                 {"path", path.string()},
                 {"type", json.type_name()},
                 {"keys", keys}};
    }
  }
  std::cout << out.dump(2) << "\n";
  return kExitOk;
}

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
    *action = [options] { return RunInspect(*options); };
  });
}

}  // namespace pano4d::cli
