#include "src/pipeline/inspect.h"

#include <algorithm>
#include <cctype>

#include <opencv2/core.hpp>

#include "src/core/camera.h"
#include "src/core/camera_check.h"
#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/video.h"

namespace pano4d {
namespace {

std::string LowerExtension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

std::string GuessKind(const std::filesystem::path& path) {
  if (std::filesystem::is_directory(path)) {
    throw Error::In(path.string(),
                    "is a folder: `pano4d inspect` reads one file; `pano4d "
                    "dataset info` describes a dataset or priors folder");
  }
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

}  // namespace

nlohmann::json Inspect(const std::filesystem::path& path, const std::string& as,
                       bool count_frames) {
  const std::string kind = as == "auto" ? GuessKind(path) : as;
  Json out;
  if (kind == "image") {
    out = InspectImage(path);
  } else if (kind == "video") {
    out = InspectVideo(path, count_frames);
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
  return out;
}

}  // namespace pano4d
