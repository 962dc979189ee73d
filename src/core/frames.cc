#include "src/core/frames.h"

#include <set>

#include <nlohmann/json.hpp>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/json.h"
#include "src/core/workspace.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// A camera this far from the origin is a corrupt pose: float32 positions
// there have no precision left for a scene's detail (the fit, its
// k-means and its Gaussians work in float).
constexpr double kMaxPoseTranslation = 1e6;

std::string Stored(const fs::path& workspace, const fs::path& path) {
  if (path.empty()) return "";
  const fs::path abs = fs::absolute(path).lexically_normal();
  const fs::path rel = abs.lexically_relative(fs::absolute(workspace));
  if (!rel.empty() && *rel.begin() != "..") return rel.generic_string();
  return abs.generic_string();
}

fs::path Loaded(const fs::path& workspace, const std::string& stored) {
  if (stored.empty()) return {};
  const fs::path p(stored);
  return p.is_absolute() ? p : workspace / p;
}

nlohmann::json FrameToJson(const fs::path& ws, const WorkspaceFrame& f) {
  const Eigen::Vector4d q = f.camera.cam_from_world.ColmapQvec();
  const Eigen::Vector3d& t = f.camera.cam_from_world.translation;
  return {{"name", f.name},
          {"time", f.time},
          {"camera", CameraToJson(f.camera.camera)},
          {"qvec", {q[0], q[1], q[2], q[3]}},
          {"tvec", {t[0], t[1], t[2]}},
          {"rgb", Stored(ws, f.rgb)},
          {"depth", Stored(ws, f.depth)},
          {"dynamic_mask", Stored(ws, f.dynamic_mask)},
          {"covisible", Stored(ws, f.covisible)}};
}

WorkspaceFrame FrameFromJson(const fs::path& ws, const nlohmann::json& j,
                             const std::string& source) {
  WorkspaceFrame f;
  f.name = GetJson<std::string>(j, "name", source);
  const std::string where = source + " frame " + f.name;
  f.time = GetJson<int>(j, "time", where);
  f.camera.camera = CameraFromJson(GetJson<Json>(j, "camera", where), where);
  const std::vector<double> q = GetJson<std::vector<double>>(j, "qvec", where);
  const std::vector<double> t = GetJson<std::vector<double>>(j, "tvec", where);
  if (q.size() != 4 || t.size() != 3) {
    throw Error(where, "qvec/tvec",
                std::to_string(q.size()) + "/" + std::to_string(t.size()),
                "expected 4 and 3 numbers");
  }
  try {
    f.camera.cam_from_world =
        Rigid3d::FromColmap(Eigen::Vector4d(q[0], q[1], q[2], q[3]),
                            Eigen::Vector3d(t[0], t[1], t[2]));
  } catch (const Error& e) {
    throw Error(where, e.field(), e.value(), e.problem());
  }
  if (f.camera.cam_from_world.translation.norm() > kMaxPoseTranslation) {
    throw Error(where, "tvec", JsonValueForMessage(j["tvec"]),
                "is farther than 1e6 scene units from the origin: a corrupt "
                "pose (no scene pano4d fits is that large)");
  }
  f.rgb = Loaded(ws, GetJson<std::string>(j, "rgb", where));
  f.depth = Loaded(ws, GetJsonOr<std::string>(j, "depth", "", where));
  f.dynamic_mask =
      Loaded(ws, GetJsonOr<std::string>(j, "dynamic_mask", "", where));
  f.covisible = Loaded(ws, GetJsonOr<std::string>(j, "covisible", "", where));
  return f;
}

}  // namespace

void WorkspaceFrames::Check(const std::string& source) const {
  if (train.empty()) {
    throw Error(source, "train", "[]", "no training frames");
  }
  // Every time is some frame's (datasets number their times densely):
  // more times than frames would have the motion model hold a pose for
  // times no frame shows.
  const std::size_t frames = train.size() + val.size();
  if (num_times < 1 || static_cast<std::size_t>(num_times) > frames) {
    throw Error(source, "num_times", std::to_string(num_times),
                "expected 1.." + std::to_string(frames) +
                    " (one time per frame at most); `pano4d depth` again "
                    "writes it from the dataset");
  }
  std::set<std::string> names;
  for (const auto* split : {&train, &val}) {
    for (const WorkspaceFrame& f : *split) {
      CheckPlainName(f.name, source, "name");
      if (!names.insert(f.name).second) {
        throw Error(source, "name", f.name, "appears twice");
      }
      if (f.time < 0 || f.time >= num_times) {
        throw Error(source, "frame " + f.name + " time", std::to_string(f.time),
                    "outside [0, " + std::to_string(num_times) + ")");
      }
      const CameraModelId model = f.camera.camera.model_id;
      if (model != CameraModelId::kSimplePinhole &&
          model != CameraModelId::kPinhole) {
        throw Error(source, "frame " + f.name + " camera",
                    std::string(GetCameraModelInfo(model).name),
                    "expected a pinhole camera (undistort the images first, "
                    "e.g. with colmap image_undistorter)");
      }
    }
  }
}

fs::path FramesPath(const fs::path& workspace) {
  return Workspace(workspace).frames_json();
}

void WriteWorkspaceFrames(const fs::path& workspace,
                          const WorkspaceFrames& frames) {
  frames.Check(FramesPath(workspace).string());
  nlohmann::json train = nlohmann::json::array(), val = nlohmann::json::array();
  for (const WorkspaceFrame& f : frames.train)
    train.push_back(FrameToJson(workspace, f));
  for (const WorkspaceFrame& f : frames.val)
    val.push_back(FrameToJson(workspace, f));
  WriteJson(FramesPath(workspace),
            {{"source", frames.source},
             {"depth_source", frames.depth_source},
             {"dataset", Stored(workspace, frames.dataset)},
             {"dataset_factor", frames.dataset_factor},
             {"num_times", frames.num_times},
             {"priors", Stored(workspace, frames.priors)},
             {"depth_options", frames.depth_options},
             {"train", train},
             {"val", val}});
}

WorkspaceFrames ReadWorkspaceFrames(const fs::path& workspace) {
  const fs::path path = FramesPath(workspace);
  if (!fs::exists(path)) {
    throw Error(path.string(), "", "",
                "missing; run `pano4d depth --workspace " + workspace.string() +
                    "` first");
  }
  const Json j = ReadJson(path);
  const std::string source = path.string();
  WorkspaceFrames frames;
  frames.source = GetJsonOr<std::string>(j, "source", "", source);
  frames.depth_source = GetJsonOr<std::string>(j, "depth_source", "", source);
  frames.num_times = GetJson<int>(j, "num_times", source);
  frames.dataset =
      Loaded(workspace, GetJsonOr<std::string>(j, "dataset", "", source));
  frames.dataset_factor = GetJsonOr<int>(j, "dataset_factor", 0, source);
  frames.priors =
      Loaded(workspace, GetJsonOr<std::string>(j, "priors", "", source));
  frames.depth_options = GetJsonOr<Json>(j, "depth_options", Json(), source);
  for (const Json& f : GetJson<Json>(j, "train", source))
    frames.train.push_back(FrameFromJson(workspace, f, source));
  for (const Json& f : GetJsonOr<Json>(j, "val", Json::array(), source))
    frames.val.push_back(FrameFromJson(workspace, f, source));
  frames.Check(source);
  return frames;
}

}  // namespace pano4d
