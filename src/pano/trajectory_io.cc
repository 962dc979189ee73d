#include "src/pano/trajectory_io.h"

#include <Eigen/Geometry>

#include "colmap_ext/model.h"
#include "src/core/file.h"
#include "src/core/json.h"

namespace pano4d {
namespace {

void AddImage(const RasterCamera& c, const std::string& name,
              ColmapModel* model) {
  const auto id = static_cast<std::uint32_t>(model->images.size() + 1);
  ColmapCamera camera;
  camera.camera_id = id;
  camera.model_id = static_cast<int>(CameraModelId::kPinhole);
  camera.width = static_cast<std::uint64_t>(c.width);
  camera.height = static_cast<std::uint64_t>(c.height);
  camera.params = {c.fx, c.fy, c.cx, c.cy};
  model->cameras.push_back(camera);
  ColmapImage image;
  image.image_id = id;
  image.camera_id = id;
  image.name = name;
  const Eigen::Quaterniond q =
      Eigen::Quaterniond(c.rotation.cast<double>()).normalized();
  image.qvec = Eigen::Vector4d(q.w(), q.x(), q.y(), q.z());
  image.tvec = c.translation.cast<double>();
  model->images.push_back(image);
}

}  // namespace

void WriteTrajectories(const std::filesystem::path& dir,
                       const std::vector<ExpandedView>& cameras,
                       const std::vector<SourceCamera>& sources) {
  Json views = Json::array();
  ColmapModel model;
  for (const SourceCamera& s : sources)
    AddImage(s.camera, "source/" + s.name + ".png", &model);
  for (const ExpandedView& v : cameras) {
    views.push_back(ToJson(v));
    AddImage(v.camera,
             "step_" + ZeroPadded(v.e, 2) + "/dir_" + std::to_string(v.m) +
                 "/" + (v.name.empty() ? ZeroPadded(v.t, 5) : v.name) + ".png",
             &model);
  }
  WriteJson(dir / "trajectories.json",
            {{"note",
              "expanded cameras (DESIGN.md eqs. dir1, dir2): m direction, e "
              "step, t time; qvec (w, x, y, z) and tvec of cam_from_world as "
              "COLMAP"},
             {"views", views}});
  model.BuildIndex();
  WriteModel(model, dir / "colmap", ColmapFormat::kText);
}

std::vector<ExpandedView> ReadTrajectories(const std::filesystem::path& path) {
  const Json j = ReadJson(path);
  const Json views = GetJson<Json>(j, "views", path.string());
  std::vector<ExpandedView> out;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const std::string source = path.string() + " view " + std::to_string(i);
    ExpandedView v;
    v.m = GetJson<int>(views[i], "m", source);
    v.e = GetJson<int>(views[i], "e", source);
    v.t = GetJson<int>(views[i], "t", source);
    v.name = GetJsonOr<std::string>(views[i], "source", "", source);
    v.camera =
        RasterCameraFromJson(GetJson<Json>(views[i], "camera", source), source);
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace pano4d
