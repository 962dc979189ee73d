#include "src/datasets/kubric_dataset.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <regex>

#include <Eigen/Geometry>

#include "src/core/error.h"
#include "src/core/json.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// View number -> metadata file, from names like scn02900_p0_v4.json.
std::map<int, fs::path> ViewFiles(const fs::path& root) {
  static const std::regex pattern(R"(^(.+)_p0_v(\d+)\.json$)");
  std::map<int, fs::path> views;
  if (!fs::is_directory(root)) return views;
  for (const auto& entry : fs::directory_iterator(root)) {
    std::smatch match;
    const std::string name = entry.path().filename().string();
    if (std::regex_match(name, match, pattern) && match[2].length() < 6) {
      views[std::stoi(match[2])] = entry.path();
    }
  }
  return views;
}

std::string Frame(const char* prefix, int t, const char* ext) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%s_%05d%s", prefix, t, ext);
  return buffer;
}

std::vector<double> Row(const Json& array, std::size_t size,
                        const std::string& source, const std::string& field) {
  if (!array.is_array() || array.size() != size) {
    throw Error(source, field, JsonValueForMessage(array),
                "expected " + std::to_string(size) + " numbers");
  }
  std::vector<double> out;
  for (const Json& v : array) {
    if (!v.is_number())
      throw Error(source, field, JsonValueForMessage(v), "expected a number");
    out.push_back(v.get<double>());
  }
  return out;
}

// A view's intrinsics: scene.resolution and camera.K (normalised by the
// image size, as Kubric writes it).
Camera ViewIntrinsics(const Json& camera, const Json& scene,
                      const std::string& source) {
  const std::vector<int> resolution =
      GetJson<std::vector<int>>(scene, "resolution", source);
  if (resolution.size() != 2 || resolution[0] <= 0 || resolution[1] <= 0) {
    throw Error(source, "scene.resolution", "",
                "expected [W, H], both positive");
  }
  const int width = resolution[0], height = resolution[1];
  const Json k = GetJson<Json>(camera, "K", source);
  if (!k.is_array() || k.size() != 3)
    throw Error(source, "camera.K", "", "expected 3x3");
  const std::vector<double> k0 = Row(k[0], 3, source, "camera.K[0]");
  const std::vector<double> k1 = Row(k[1], 3, source, "camera.K[1]");
  const Camera intrinsics{CameraModelId::kPinhole,
                          width,
                          height,
                          {std::abs(k0[0]) * width, std::abs(k1[1]) * height,
                           std::abs(k0[2]) * width, std::abs(k1[2]) * height}};
  intrinsics.Check(source);
  return intrinsics;
}

// Frame t's pose from Blender's camera position and quaternion (axes x
// right, y up, z back) in OpenCV's (negate y, z).
Rigid3d CamFromWorld(const Json& quaternions, const Json& positions, int t,
                     const std::string& source) {
  const std::vector<double> q =
      Row(quaternions[t], 4, source,
          "camera.quaternions[" + std::to_string(t) + "]");
  const std::vector<double> p = Row(
      positions[t], 3, source, "camera.positions[" + std::to_string(t) + "]");
  const Rigid3d world_from_blender =
      Rigid3d::FromColmap({q[0], q[1], q[2], q[3]}, {p[0], p[1], p[2]});
  Eigen::Matrix3d world_from_cam =
      world_from_blender.rotation.toRotationMatrix();
  world_from_cam.col(1) *= -1;
  world_from_cam.col(2) *= -1;
  const Eigen::Quaterniond cam_from_world(world_from_cam.transpose());
  return Rigid3d(cam_from_world.normalized(),
                 -(cam_from_world * world_from_blender.translation));
}

// One view's frames (its metadata file at `path`) into the dataset.
void ReadView(const fs::path& root, int view, const fs::path& path,
              Dataset* dataset) {
  const std::string source = path.string();
  const Json meta = ReadJson(path);
  const Json camera = GetJson<Json>(meta, "camera", source);
  const Json scene = GetJson<Json>(meta, "scene", source);
  const int frames = GetJson<int>(scene, "num_frames", source);
  // Kubric's get_scene_metadata writes scene.frame_rate (24 for GCD).
  dataset->fps = GetJsonOr<double>(scene, "frame_rate", dataset->fps, source);
  const Camera intrinsics = ViewIntrinsics(camera, scene, source);
  const Json positions = GetJson<Json>(camera, "positions", source);
  const Json quaternions = GetJson<Json>(camera, "quaternions", source);
  if (!positions.is_array() || !quaternions.is_array() ||
      static_cast<int>(positions.size()) < frames ||
      static_cast<int>(quaternions.size()) < frames) {
    throw Error(source, "camera.positions",
                std::to_string(positions.size()) + " entries",
                "expected one position and one quaternion per frame (" +
                    std::to_string(frames) + ")");
  }
  dataset->num_times = std::max(dataset->num_times, frames);
  const fs::path frames_dir = root / ("frames_p0_v" + std::to_string(view));
  for (int t = 0; t < frames; ++t) {
    DatasetFrame frame;
    frame.camera_id = view;
    frame.time_id = t;
    char id[32];
    std::snprintf(id, sizeof(id), "v%d_t%05d", view, t);
    frame.id = id;
    frame.camera = PosedCamera{intrinsics,
                               CamFromWorld(quaternions, positions, t, source)};
    frame.rgb = frames_dir / Frame("rgba", t, ".png");
    const fs::path depth = frames_dir / Frame("depth", t, ".tiff");
    if (fs::exists(depth)) frame.depth = depth;
    frame.depth_convention = DepthConvention::kRayDistance;
    (view == kKubricTrainView ? dataset->train : dataset->val).push_back(frame);
  }
}

}  // namespace

bool LooksLikeKubric4D(const fs::path& root) {
  return !ViewFiles(root).empty();
}

Dataset ReadKubric4D(const fs::path& root, int factor) {
  if (factor != 1) {
    throw Error::In(root.string(),
                    "Kubric-4D has only full-resolution (1x) frames; got "
                    "factor " +
                        std::to_string(factor) + " (pass --factor 1)");
  }
  const std::map<int, fs::path> views = ViewFiles(root);
  if (views.empty())
    throw Error::In(root.string(), "no <scene>_p0_v<V>.json metadata files");
  if (!views.count(kKubricTrainView)) {
    throw Error::In(root.string(),
                    "view " + std::to_string(kKubricTrainView) +
                        " (the training view) has no metadata file");
  }
  Dataset dataset;
  dataset.kind = DatasetKind::kKubric4D;
  dataset.root = root;
  dataset.factor = 1;
  for (const auto& [view, path] : views) ReadView(root, view, path, &dataset);
  return dataset;
}

}  // namespace pano4d
