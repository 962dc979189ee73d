#include "src/datasets/dycheck_dataset.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "src/core/error.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/datasets/dycheck_camera.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

std::string FactorFolder(int factor) { return std::to_string(factor) + "x"; }

std::vector<DatasetFrame> ReadSplit(const fs::path& root,
                                    const std::string& split, int factor) {
  const fs::path path = root / "splits" / (split + ".json");
  std::vector<DatasetFrame> frames;
  for (const DyCheckSplitEntry& entry :
       ParseDyCheckSplit(ReadJson(path), path.string())) {
    DatasetFrame frame;
    frame.id = entry.id;
    frame.camera_id = entry.camera_id;
    frame.time_id = entry.time_id;
    const fs::path camera_path = root / "camera" / (frame.id + ".json");
    const PosedCamera full = ReadDyCheckCamera(camera_path);
    frame.camera = full;
    if (factor != 1) {
      frame.camera.camera = full.camera.Rescaled(
          static_cast<int>(
              std::lround(full.camera.width / static_cast<double>(factor))),
          static_cast<int>(
              std::lround(full.camera.height / static_cast<double>(factor))));
    }
    const std::string folder = FactorFolder(factor);
    frame.rgb = root / "rgb" / folder / (frame.id + ".png");
    const fs::path depth = root / "depth" / folder / (frame.id + ".npy");
    if (fs::exists(depth)) frame.depth = depth;
    if (split == "val") {
      const fs::path covisible =
          root / "covisible" / folder / "val" / (frame.id + ".png");
      if (fs::exists(covisible)) frame.covisible = covisible;
    }
    frames.push_back(std::move(frame));
  }
  return frames;
}

Json Vector(const Eigen::Vector3d& v) { return Json{v.x(), v.y(), v.z()}; }

Eigen::Vector3d ReadVector(const Json& json, const std::string& key,
                           const std::string& source) {
  const std::vector<double> v = GetJson<std::vector<double>>(json, key, source);
  if (v.size() != 3)
    throw Error(source, key, std::to_string(v.size()) + " values",
                "expected 3");
  return {v[0], v[1], v[2]};
}

// dataset.json and metadata.json repeat what the splits say; a scene where
// they disagree was assembled wrongly, and which to trust is not ours to
// guess.
void CheckConsistency(const fs::path& root, const Dataset& dataset) {
  const fs::path dataset_path = root / "dataset.json";
  const Json index = ReadJson(dataset_path);
  const std::vector<std::pair<const char*, const std::vector<DatasetFrame>*>>
      splits = {{"train_ids", &dataset.train}, {"val_ids", &dataset.val}};
  for (const auto& [key, frames] : splits) {
    if (!index.contains(key)) continue;
    const Json ids = GetJson<Json>(index, key, dataset_path.string());
    if (!ids.is_array() || ids.size() != frames->size()) {
      throw Error(dataset_path.string(), key,
                  std::to_string(ids.is_array() ? ids.size() : 0) + " ids",
                  "disagrees with splits/ (" + std::to_string(frames->size()) +
                      " frames)");
    }
    for (std::size_t i = 0; i < ids.size(); ++i) {
      if (ids[i] != (*frames)[i].id) {
        throw Error(dataset_path.string(),
                    std::string(key) + "[" + std::to_string(i) + "]",
                    JsonValueForMessage(ids[i]),
                    "disagrees with splits/ ('" + (*frames)[i].id + "')");
      }
    }
  }
  const fs::path metadata_path = root / "metadata.json";
  if (!fs::exists(metadata_path)) return;
  const Json metadata = ReadJson(metadata_path);
  for (const auto& [key, frames] : splits) {
    for (const DatasetFrame& f : *frames) {
      if (!metadata.contains(f.id)) continue;
      const int camera = GetJson<int>(metadata[f.id], "camera_id",
                                      metadata_path.string() + " " + f.id);
      if (camera != f.camera_id) {
        throw Error(
            metadata_path.string(), f.id + ".camera_id", std::to_string(camera),
            "disagrees with splits/ (" + std::to_string(f.camera_id) + ")");
      }
    }
  }
}

Json SplitJson(const std::vector<DyCheckScene::Frame>& frames) {
  Json names = Json::array(), cameras = Json::array(), times = Json::array();
  for (const auto& f : frames) {
    names.push_back(DyCheckFrameId(f.camera_id, f.time_id));
    cameras.push_back(f.camera_id);
    times.push_back(f.time_id);
  }
  return Json{
      {"frame_names", names}, {"camera_ids", cameras}, {"time_ids", times}};
}

}  // namespace

std::vector<DyCheckSplitEntry> ParseDyCheckSplit(const Json& json,
                                                 const std::string& source) {
  const auto names = GetJson<Json>(json, "frame_names", source);
  const std::vector<int> cameras =
      GetJson<std::vector<int>>(json, "camera_ids", source);
  const std::vector<int> times =
      GetJson<std::vector<int>>(json, "time_ids", source);
  if (!names.is_array() || names.size() != cameras.size() ||
      names.size() != times.size()) {
    throw Error(
        source, "frame_names", std::to_string(names.size()) + " entries",
        "frame_names, camera_ids and time_ids must have the same length");
  }
  std::vector<DyCheckSplitEntry> entries;
  entries.reserve(names.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    const auto field = [i](const std::string& list) {
      return list + "[" + std::to_string(i) + "]";
    };
    if (!names[i].is_string()) {
      throw Error(source, field("frame_names"), JsonValueForMessage(names[i]),
                  "expected a string");
    }
    DyCheckSplitEntry entry{names[i].get<std::string>(), cameras[i], times[i]};
    if (entry.id.empty() || entry.id.find('/') != std::string::npos ||
        entry.id == "." || entry.id == "..") {
      throw Error(source, field("frame_names"), "\"" + entry.id + "\"",
                  "not a valid frame name");
    }
    if (entry.time_id < 0) {
      throw Error(source, field("time_ids"), std::to_string(entry.time_id),
                  "must be >= 0");
    }
    entries.push_back(std::move(entry));
  }
  return entries;
}

int MakeTimeIdsDense(std::vector<DatasetFrame*> frames,
                     const std::string& source) {
  std::vector<int> times;
  for (const DatasetFrame* f : frames) times.push_back(f->time_id);
  std::sort(times.begin(), times.end());
  times.erase(std::unique(times.begin(), times.end()), times.end());
  if (times.empty()) return 0;
  if (times.back() == static_cast<int>(times.size()) - 1)
    return static_cast<int>(times.size());
  PANO4D_LOG(kWarning) << source << ": time ids 0.." << times.back() << " name "
                       << times.size() << " times; numbered 0.."
                       << times.size() - 1
                       << " in their order (the motion model holds one "
                          "pose per time)";
  for (DatasetFrame* f : frames) {
    f->time_id = static_cast<int>(
        std::lower_bound(times.begin(), times.end(), f->time_id) -
        times.begin());
  }
  return static_cast<int>(times.size());
}

bool LooksLikeDyCheck(const fs::path& root) {
  return fs::is_regular_file(root / "dataset.json") &&
         fs::is_directory(root / "splits") && fs::is_directory(root / "camera");
}

Dataset ReadDyCheck(const fs::path& root, int factor) {
  if (factor != 1 && factor != 2) {
    throw Error(root.string(), "factor", std::to_string(factor),
                "DyCheck ships 1x and 2x folders; use 1 or 2");
  }
  Dataset dataset;
  dataset.kind = DatasetKind::kDyCheck;
  dataset.root = root;
  dataset.factor = factor;
  dataset.train = ReadSplit(root, "train", factor);
  dataset.val = ReadSplit(root, "val", factor);
  std::vector<DatasetFrame*> frames;
  for (auto* split : {&dataset.train, &dataset.val})
    for (DatasetFrame& f : *split) frames.push_back(&f);
  dataset.num_times =
      MakeTimeIdsDense(frames, (root / "splits").string() + "/*.json");
  const fs::path extra_path = root / "extra.json";
  if (fs::exists(extra_path)) {
    const Json extra = ReadJson(extra_path);
    dataset.fps = GetJsonOr<double>(extra, "fps", 0.0, extra_path.string());
    if (extra.contains("lookat"))
      dataset.lookat = ReadVector(extra, "lookat", extra_path.string());
    if (extra.contains("up"))
      dataset.up = ReadVector(extra, "up", extra_path.string());
  }
  const fs::path scene_path = root / "scene.json";
  if (fs::exists(scene_path)) {
    const Json scene = ReadJson(scene_path);
    const double scale = GetJson<double>(scene, "scale", scene_path.string());
    if (!(scale > 0))
      throw Error(scene_path.string(), "scale", std::to_string(scale),
                  "must be positive");
    dataset.scene_scale = scale;
    dataset.scene_center = ReadVector(scene, "center", scene_path.string());
    dataset.near = GetJson<double>(scene, "near", scene_path.string()) / scale;
    dataset.far = GetJson<double>(scene, "far", scene_path.string()) / scale;
  }
  CheckConsistency(root, dataset);
  return dataset;
}

std::string DyCheckFrameId(int camera_id, int time_id) {
  char id[32];
  std::snprintf(id, sizeof(id), "%d_%05d", camera_id, time_id);
  return id;
}

void WriteDyCheckMetadata(const fs::path& root, const DyCheckScene& scene) {
  Json ids = Json::array(), train_ids = Json::array(), val_ids = Json::array();
  Json metadata = Json::object();
  for (const auto* split : {&scene.train, &scene.val}) {
    for (const auto& f : *split) {
      const std::string id = DyCheckFrameId(f.camera_id, f.time_id);
      WriteDyCheckCamera(root / "camera" / (id + ".json"), f.camera);
      ids.push_back(id);
      (split == &scene.train ? train_ids : val_ids).push_back(id);
      metadata[id] = Json{{"warp_id", f.time_id},
                          {"appearance_id", f.time_id},
                          {"camera_id", f.camera_id}};
    }
  }
  WriteJson(root / "splits" / "train.json", SplitJson(scene.train), 4);
  WriteJson(root / "splits" / "val.json", SplitJson(scene.val), 4);
  WriteJson(root / "dataset.json",
            Json{{"count", ids.size()},
                 {"num_exemplars", train_ids.size()},
                 {"ids", ids},
                 {"train_ids", train_ids},
                 {"val_ids", val_ids}},
            4);
  WriteJson(root / "scene.json",
            Json{{"scale", scene.scale},
                 {"center", Vector(scene.center)},
                 {"near", scene.near * scene.scale},
                 {"far", scene.far * scene.scale}},
            4);
  WriteJson(root / "metadata.json", metadata, 4);
  WriteJson(root / "extra.json",
            Json{{"factor", 2},
                 {"fps", scene.fps},
                 {"bbox", {Vector(scene.bbox_min), Vector(scene.bbox_max)}},
                 {"lookat", Vector(scene.lookat)},
                 {"up", Vector(scene.up)}},
            4);
}

}  // namespace pano4d
