#include "colmap_ext/register_left_out.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "colmap_ext/database.h"
#include "src/core/log.h"

namespace pano4d {
namespace {

// RANSAC's iterations and confidence: at a 15% inlier share P3P needs
// about 2000 draws for 99.9%, which takes milliseconds.
constexpr int kRansacIterations = 2000;
constexpr double kRansacConfidence = 0.999;

// A keypoint of the left-out frame and the model point it sees.
struct Correspondence {
  std::uint32_t keypoint = 0;
  std::uint64_t point3D_id = 0;
};

// The frame's keypoints that verified matches tie to points of `model`,
// one point per keypoint (the first match that names one).
std::vector<Correspondence> CorrespondencesOf(
    std::uint32_t frame, const std::vector<const DatabasePair*>& pairs,
    const ColmapModel& model) {
  std::map<std::uint32_t, std::uint64_t> by_keypoint;
  for (const DatabasePair* pair : pairs) {
    const bool first = pair->image_id1 == frame;
    const ColmapImage* other =
        model.FindImage(first ? pair->image_id2 : pair->image_id1);
    if (other == nullptr) continue;
    for (const auto& match : pair->matches) {
      const std::uint32_t mine = match[first ? 0 : 1];
      const std::uint32_t theirs = match[first ? 1 : 0];
      if (theirs >= other->points2D.size()) continue;
      const ColmapPoint2D& seen = other->points2D[theirs];
      if (seen.HasPoint3D()) by_keypoint.emplace(mine, seen.point3D_id);
    }
  }
  std::vector<Correspondence> out;
  for (const auto& [keypoint, point] : by_keypoint)
    out.push_back({keypoint, point});
  return out;
}

// The pose of one frame, with the correspondences it keeps; nullopt when
// the evidence is too thin.
struct Pose {
  Rigid3d cam_from_world;
  std::vector<Correspondence> inliers;
};

std::optional<Pose> SolvePose(const std::vector<Correspondence>& candidates,
                              const std::vector<Eigen::Vector2d>& keypoints,
                              const Camera& camera, const ColmapModel& model,
                              const LeftOutOptions& o) {
  std::vector<cv::Point3d> world;
  std::vector<cv::Point2d> normalized;
  std::vector<Correspondence> used;
  for (const Correspondence& c : candidates) {
    if (c.keypoint >= keypoints.size()) continue;
    const ColmapPoint3D* point = model.FindPoint3D(c.point3D_id);
    const UnprojectResult ray = camera.Unproject(keypoints[c.keypoint]);
    if (point == nullptr || !ray.ok()) continue;
    world.emplace_back(point->xyz.x(), point->xyz.y(), point->xyz.z());
    normalized.emplace_back(ray.normalized.x(), ray.normalized.y());
    used.push_back(c);
  }
  if (static_cast<int>(used.size()) < o.min_inliers) return std::nullopt;
  // Normalized coordinates: the camera matrix is the identity and the
  // threshold is in units of the focal length.
  const double threshold = o.max_error_px / camera.focal_x();
  cv::Mat rvec, tvec, inlier_rows;
  if (!cv::solvePnPRansac(world, normalized, cv::Mat::eye(3, 3, CV_64F),
                          cv::noArray(), rvec, tvec, false, kRansacIterations,
                          threshold, kRansacConfidence, inlier_rows,
                          cv::SOLVEPNP_AP3P) ||
      inlier_rows.rows < o.min_inliers) {
    return std::nullopt;
  }
  std::vector<cv::Point3d> world_in;
  std::vector<cv::Point2d> normalized_in;
  for (int r = 0; r < inlier_rows.rows; ++r) {
    const int k = inlier_rows.at<int>(r);
    world_in.push_back(world[k]);
    normalized_in.push_back(normalized[k]);
  }
  cv::solvePnPRefineLM(world_in, normalized_in, cv::Mat::eye(3, 3, CV_64F),
                       cv::noArray(), rvec, tvec);
  cv::Mat rotation_cv;
  cv::Rodrigues(rvec, rotation_cv);
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  cv::cv2eigen(rotation_cv, rotation);
  cv::cv2eigen(tvec, translation);
  if (!rotation.allFinite() || !translation.allFinite()) return std::nullopt;
  const Rigid3d pose(Eigen::Quaterniond(rotation).normalized(), translation);
  // The inliers after refinement, in front of the camera and within the
  // threshold: RANSAC's reprojection does not see a point behind the camera.
  Pose out{pose, {}};
  for (std::size_t k = 0; k < used.size(); ++k) {
    const Eigen::Vector3d p =
        pose * Eigen::Vector3d(world[k].x, world[k].y, world[k].z);
    if (!(p.z() > 0.0)) continue;
    const double error = std::hypot(p.x() / p.z() - normalized[k].x,
                                    p.y() / p.z() - normalized[k].y);
    if (error <= threshold) out.inliers.push_back(used[k]);
  }
  const int n = static_cast<int>(out.inliers.size());
  if (n < o.min_inliers || n < o.min_inlier_ratio * used.size())
    return std::nullopt;
  return out;
}

// Adds the frame to `model` with its keypoints and inlier observations;
// `point_index` maps a point id to its place in model->points3D. The
// caller rebuilds the model's index.
void AddFrame(const DatabaseImage& frame,
              const std::vector<Eigen::Vector2d>& keypoints, const Pose& pose,
              const std::map<std::uint64_t, std::size_t>& point_index,
              ColmapModel* model) {
  ColmapImage image;
  image.image_id = frame.image_id;
  image.camera_id = frame.camera_id;
  image.name = frame.name;
  image.SetCamFromWorld(pose.cam_from_world);
  image.points2D.resize(keypoints.size());
  for (std::size_t k = 0; k < keypoints.size(); ++k)
    image.points2D[k].xy = keypoints[k];
  std::set<std::uint64_t> observed;  // one observation per point and image
  for (const Correspondence& c : pose.inliers) {
    if (!observed.insert(c.point3D_id).second) continue;
    image.points2D[c.keypoint].point3D_id = c.point3D_id;
    model->points3D[point_index.at(c.point3D_id)].track.push_back(
        {frame.image_id, c.keypoint});
  }
  model->images.push_back(std::move(image));
}

}  // namespace

LeftOutReport RegisterLeftOutFrames(const std::filesystem::path& database,
                                    ColmapModel* model,
                                    const LeftOutOptions& options) {
  LeftOutReport report;
  const std::vector<DatabaseImage> images = ReadDatabaseImages(database);
  std::vector<const DatabaseImage*> left_out;
  for (const DatabaseImage& image : images) {
    if (model->FindImage(image.image_id) == nullptr) left_out.push_back(&image);
  }
  report.left_out = static_cast<int>(left_out.size());
  if (left_out.empty() || model->points3D.empty()) return report;

  const std::vector<DatabasePair> pairs =
      ReadDatabasePairs(database, /*with_matches=*/true);
  const auto keypoints = ReadDatabaseKeypoints(database);
  // Points are only observed here, never added: one index serves all.
  std::map<std::uint64_t, std::size_t> point_index;
  for (std::size_t i = 0; i < model->points3D.size(); ++i)
    point_index[model->points3D[i].point3D_id] = i;
  std::map<std::uint32_t, std::vector<const DatabasePair*>> pairs_of;
  for (const DatabasePair& pair : pairs) {
    pairs_of[pair.image_id1].push_back(&pair);
    pairs_of[pair.image_id2].push_back(&pair);
  }
  // Rounds: the frame with the most correspondences first, as the mapper
  // chooses its next image; a posed frame can tie others to the points.
  for (bool progress = true; progress && !left_out.empty();) {
    progress = false;
    std::vector<std::pair<std::vector<Correspondence>, const DatabaseImage*>>
        candidates;
    for (const DatabaseImage* frame : left_out) {
      candidates.emplace_back(
          CorrespondencesOf(frame->image_id, pairs_of[frame->image_id], *model),
          frame);
    }
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const auto& a, const auto& b) {
                       return a.first.size() > b.first.size();
                     });
    for (const auto& [correspondences, frame] : candidates) {
      const ColmapCamera* camera = model->FindCamera(frame->camera_id);
      const auto kp = keypoints.find(frame->image_id);
      if (camera == nullptr || kp == keypoints.end()) continue;
      const std::optional<Pose> pose =
          SolvePose(correspondences, kp->second, ToCamera(*camera, "model"),
                    *model, options);
      if (!pose) continue;
      AddFrame(*frame, kp->second, *pose, point_index, model);
      report.posed.push_back(frame->name);
      PANO4D_LOG(kInfo) << "sfm: posed left-out frame " << frame->name
                        << " by PnP on " << pose->inliers.size() << " of "
                        << correspondences.size() << " correspondences";
      progress = true;
    }
    model->BuildIndex();
    std::erase_if(left_out, [&](const DatabaseImage* frame) {
      return model->FindImage(frame->image_id) != nullptr;
    });
  }
  return report;
}

}  // namespace pano4d
