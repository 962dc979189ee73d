#include "src/datasets/dataset.h"

#include <map>
#include <set>

#include "src/core/error.h"
#include "src/core/json.h"
#include "src/core/strings.h"
#include "src/datasets/dycheck_dataset.h"
#include "src/datasets/kubric_dataset.h"
#include "src/datasets/nvidia_dataset.h"

namespace pano4d {
namespace fs = std::filesystem;

std::string_view ToString(DatasetKind kind) {
  switch (kind) {
    case DatasetKind::kDyCheck:
      return "dycheck";
    case DatasetKind::kNvidia:
      return "nvidia";
    case DatasetKind::kKubric4D:
      return "kubric4d";
    case DatasetKind::kHeldOut:
      return "held-out";
  }
  return "unknown";
}

namespace {

Json SplitInfo(const std::vector<DatasetFrame>& frames) {
  std::map<int, int> per_camera;
  std::map<std::string, int> sizes;
  int rgb = 0, depth = 0, covisible = 0;
  for (const DatasetFrame& f : frames) {
    ++per_camera[f.camera_id];
    ++sizes[SizeText(f.camera.camera.width, f.camera.camera.height)];
    rgb += fs::exists(f.rgb) ? 1 : 0;
    depth += f.depth.empty() ? 0 : 1;
    covisible += f.covisible.empty() ? 0 : 1;
  }
  Json cameras = Json::object();
  for (const auto& [camera, count] : per_camera)
    cameras[std::to_string(camera)] = count;
  Json image_sizes = Json::object();
  for (const auto& [size, count] : sizes) image_sizes[size] = count;
  return Json{{"frames", frames.size()},    {"frames_per_camera", cameras},
              {"image_sizes", image_sizes}, {"rgb_present", rgb},
              {"depth_present", depth},     {"covisible_present", covisible}};
}

}  // namespace

Json DatasetInfo(const Dataset& dataset) {
  Json info{{"kind", std::string(ToString(dataset.kind))},
            {"root", dataset.root.string()},
            {"factor", dataset.factor},
            {"fps", dataset.fps},
            {"num_times", dataset.num_times},
            {"train", SplitInfo(dataset.train)},
            {"val", SplitInfo(dataset.val)}};
  info["near"] = dataset.near ? Json(*dataset.near) : Json(nullptr);
  info["far"] = dataset.far ? Json(*dataset.far) : Json(nullptr);
  return info;
}

std::string SplitDescription(const Dataset& dataset) {
  const auto split = [](const char* name,
                        const std::vector<DatasetFrame>& frames) {
    std::set<int> cameras;
    for (const DatasetFrame& f : frames) cameras.insert(f.camera_id);
    std::string ids;
    if (cameras.size() > 2 && *cameras.rbegin() - *cameras.begin() + 1 ==
                                  static_cast<int>(cameras.size())) {
      ids = std::to_string(*cameras.begin()) + ".." +
            std::to_string(*cameras.rbegin());
    } else {
      for (const int c : cameras)
        ids += (ids.empty() ? "" : ", ") + std::to_string(c);
    }
    return std::string(name) + ": camera" + (cameras.size() == 1 ? " " : "s ") +
           ids + ", " + std::to_string(frames.size()) + " frames";
  };
  std::string size;
  if (!dataset.val.empty() || !dataset.train.empty()) {
    const Camera& c = (dataset.val.empty() ? dataset.train : dataset.val)
                          .front()
                          .camera.camera;
    size = SizeText(c.width, c.height) + " ";
  }
  return split("train", dataset.train) + "; " + split("val", dataset.val) +
         "; " + size + "(factor " + std::to_string(dataset.factor) + ")";
}

namespace {

Dataset Detect(const fs::path& root, int factor) {
  const int f = factor == kProtocolFactor ? kEvaluationFactor : factor;
  if (LooksLikeDyCheck(root)) return ReadDyCheck(root, f);
  if (LooksLikeNvidia(root)) return ReadNvidia(root, f);
  if (LooksLikeKubric4D(root))
    return ReadKubric4D(root, factor == kProtocolFactor ? 1 : factor);
  throw Error::In(root.string(),
                  "not a dataset pano4d knows: expected the DyCheck iPhone "
                  "layout (dataset.json, "
                  "splits/, camera/), Nvidia Dynamic Scenes (poses_bounds.npy) "
                  "or Kubric-4D "
                  "(<scene>_p0_v<V>.json)");
}

}  // namespace

Dataset LoadDataset(const fs::path& root, int factor) {
  if (!fs::is_directory(root))
    throw Error::In(root.string(), "is not a directory");
  Dataset dataset = Detect(root, factor);
  // Nvidia scenes may keep their files in <scene>/dense/.
  const fs::path folder = fs::absolute(root).lexically_normal();
  const fs::path named =
      folder.filename().empty() ? folder.parent_path() : folder;
  dataset.scene = named.filename() == "dense"
                      ? named.parent_path().filename().string()
                      : named.filename().string();
  return dataset;
}

}  // namespace pano4d
