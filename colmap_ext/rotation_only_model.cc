#include "colmap_ext/rotation_only_model.h"

#include <cmath>
#include <map>
#include <set>
#include <vector>

#include <Eigen/Geometry>

#include "colmap_ext/database.h"
#include "colmap_ext/sfm_diagnosis.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/log.h"
#include "src/geometry/rotation_only.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// Above this share of verified pairs that COLMAP explains by a homography
// (PANORAMIC, PLANAR_OR_PANORAMIC) the rotation-only model is tried before
// the mapper: on a pan the mapper either fails or, now and then, builds a
// model of a moving camera from noise (7 degrees off, measured).
constexpr double kRotationOnlyPairShare = 0.9;
// A camera that also moves leaves parallax the rotation-only model cannot
// explain: it is kept only when its transfer error stays below this
// (pixels; measured on the synthetic small scene at 480x360: 0.57 on a
// pan, 1.22 on the 7-degree slow arc).
constexpr double kRotationOnlyMaxRms = 0.8;

// The share of verified pairs that are rotation-only.
double RotationOnlyPairShare(const std::vector<DatabasePair>& pairs) {
  int verified = 0, rotation_only = 0;
  for (const DatabasePair& p : pairs) {
    if (p.inliers < kMinPairInliers) continue;
    ++verified;
    rotation_only +=
        p.config == static_cast<int>(PairConfig::kPanoramic) ||
        p.config == static_cast<int>(PairConfig::kPlanarOrPanoramic);
  }
  return verified > 0 ? static_cast<double>(rotation_only) / verified : 0.0;
}

// Rotation-only frames closer than this to each other (degrees) are one
// still camera: a tripod's, whose frames differ by noise.
constexpr double kStillDegrees = 0.1;

// The rotation-only model of a camera that turns about a fixed centre: the
// rotations and focal length of the verified pairs' matches
// (src/geometry/rotation_only.h), for the database's images in id order
// and `pairs` with their matches.
RotationOnlyEstimate EstimateFromDatabase(
    const fs::path& database, const std::vector<DatabaseImage>& images,
    const std::vector<DatabasePair>& pairs, int width, int height) {
  std::map<std::uint32_t, int> frame_of;
  for (std::size_t k = 0; k < images.size(); ++k)
    frame_of[images[k].image_id] = static_cast<int>(k);
  const auto keypoints = ReadDatabaseKeypoints(database);
  std::vector<FrameMatches> matches;
  for (const DatabasePair& pair : pairs) {
    const auto i = frame_of.find(pair.image_id1);
    const auto j = frame_of.find(pair.image_id2);
    const auto ki = keypoints.find(pair.image_id1);
    const auto kj = keypoints.find(pair.image_id2);
    if (i == frame_of.end() || j == frame_of.end() || ki == keypoints.end() ||
        kj == keypoints.end())
      continue;
    FrameMatches m{i->second, j->second, {}, {}};
    for (const auto& [a, b] : pair.matches) {
      if (a >= ki->second.size() || b >= kj->second.size()) {
        throw Error(database.string(), "two_view_geometries",
                    std::to_string(a) + "," + std::to_string(b),
                    "a match refers to a keypoint its image lacks");
      }
      m.xi.push_back(ki->second[a]);
      m.xj.push_back(kj->second[b]);
    }
    matches.push_back(std::move(m));
  }
  return EstimateRotationOnly(static_cast<int>(images.size()), width, height,
                              matches);
}

// The estimate as a COLMAP model in `out`: every centre at the origin, one
// PINHOLE camera per database camera, no points (nothing can be
// triangulated).
void WriteModelOf(const std::vector<DatabaseImage>& images,
                  const RotationOnlyEstimate& e, const fs::path& out) {
  ColmapModel model;
  std::set<std::uint32_t> cameras;
  const Camera pinhole{CameraModelId::kPinhole,
                       e.width,
                       e.height,
                       {e.focal, e.focal, e.width / 2.0, e.height / 2.0}};
  for (std::size_t k = 0; k < images.size(); ++k) {
    if (!e.cam_from_world[k]) continue;
    if (cameras.insert(images[k].camera_id).second)
      model.cameras.push_back(FromCamera(images[k].camera_id, pinhole));
    ColmapImage image;
    image.image_id = images[k].image_id;
    image.camera_id = images[k].camera_id;
    image.name = images[k].name;
    image.SetCamFromWorld(
        Rigid3d(Eigen::Quaterniond(*e.cam_from_world[k]).normalized(),
                Eigen::Vector3d::Zero()));
    model.images.push_back(std::move(image));
  }
  model.BuildIndex();
  fs::remove_all(out);
  EnsureDirectory(out);
  WriteModel(model, out, ColmapFormat::kBinary);
}

}  // namespace

bool TryRotationOnlyModel(const fs::path& database, int width, int height,
                          const fs::path& out) {
  const std::vector<DatabasePair> pairs =
      ReadDatabasePairs(database, /*with_matches=*/true);
  const double share = RotationOnlyPairShare(pairs);
  if (!(share > kRotationOnlyPairShare)) return false;
  const std::vector<DatabaseImage> images = ReadDatabaseImages(database);
  try {
    const RotationOnlyEstimate e =
        EstimateFromDatabase(database, images, pairs, width, height);
    const bool kept = e.rms_pixels < kRotationOnlyMaxRms && e.Posed() >= 2;
    PANO4D_LOG(kInfo) << "sfm: " << 100 * share
                      << "% of the verified pairs fit a homography; "
                         "rotation-only model: "
                      << e.Posed() << " of " << images.size()
                      << " frames, focal " << e.focal << " px, transfer rms "
                      << e.rms_pixels << " px"
                      << (kept ? " (kept)"
                               : " (the camera moves too: the mapper instead)");
    if (kept) WriteModelOf(images, e, out);
    return kept;
  } catch (const Error& e) {
    PANO4D_LOG(kInfo) << "sfm: no rotation-only model (" << e.what()
                      << "); the mapper instead";
    return false;
  }
}

bool IsRotationOnly(const ColmapModel& model) {
  if (!model.points3D.empty() || model.images.size() < 2) return false;
  const Eigen::Vector3d first = model.images.front().Center();
  for (const ColmapImage& image : model.images)
    if ((image.Center() - first).norm() > 1e-9) return false;
  return true;
}

bool IsStaticCamera(const ColmapModel& model) {
  if (!IsRotationOnly(model)) return false;
  const Eigen::Quaterniond first = model.images.front().CamFromWorld().rotation;
  for (const ColmapImage& image : model.images) {
    if (image.CamFromWorld().rotation.angularDistance(first) * 180 / M_PI >
        kStillDegrees)
      return false;
  }
  return true;
}

}  // namespace pano4d
