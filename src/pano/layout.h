#pragma once

#include <array>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "src/geometry/point_cloud.h"
#include "src/render/gaussians.h"

namespace pano4d {

// A box-shaped proxy of a scene's static layout (its floor and walls): the
// surface an expanded view's hole shows when no frame saw what is there.
// The holes' content is placed where its ray leaves the box, not on a sheet
// at the depth of the hole's border (which, for a view across the room,
// floats mid-room in front of other cameras), and it takes the colour of
// the face it lies on: a fitted plane's mean colour (the floor continues
// the floor's colour), or the scene's mean colour on a face no frame saw
// (the colour that errs least on content nothing says anything about).
struct Layout {
  bool valid = false;
  // Columns: the box's unit axes in the world (a rotation).
  Eigen::Matrix3f axes = Eigen::Matrix3f::Identity();
  // The box along its axes: lo[j] <= axes.col(j) . x <= hi[j].
  Eigen::Vector3f lo = Eigen::Vector3f::Zero();
  Eigen::Vector3f hi = Eigen::Vector3f::Zero();
  // Faces in the order -axis0, +axis0, -axis1, +axis1, -axis2, +axis2.
  std::array<Eigen::Vector3f, 6> colours{};
  std::array<bool, 6> on_plane{};  // the face lies on a fitted plane
  Eigen::Vector3f mean_colour = Eigen::Vector3f::Constant(0.5f);
  // The planes' inlier band (world units): how far a point may lie off a
  // plane and still be on it.
  float band = 0;

  // Where the ray origin + t direction leaves the box (t > 0; with an
  // unnormalised direction, t is in its units): the exit from inside, the
  // far side from outside. nullopt when it misses, or when invalid.
  struct Hit {
    float t = 0;
    int face = 0;
  };
  std::optional<Hit> Exit(const Eigen::Vector3f& origin,
                          const Eigen::Vector3f& direction) const;

  // The face on a fitted plane that `point` lies on: within `tolerance`
  // (world units) of the face, and inside the box, with that tolerance to
  // spare, along the two other axes. nullopt when it lies on no plane face,
  // or when invalid.
  std::optional<int> PlaneFaceAt(const Eigen::Vector3f& point,
                                 float tolerance) const;

  // Whether `point` lies past a face that is no plane, by more than the
  // band, and off every plane face's plane (the floor runs on beyond the
  // box): where a wall that frames saw only in slivers stands
  // (FitSliverWalls). False when invalid.
  bool Beyond(const Eigen::Vector3f& point) const;
};

// The layout of a static point cloud (RGB in [0, 1]) seen from
// `viewpoints` (the cameras' centres): up to four dominant planes (RANSAC),
// the box's axes from the largest plane's normal and the next
// near-orthogonal one (else the points' principal direction), its extent
// the points' 1st to 99th percentile along each axis, widened to take in a
// plane that is a face (a plane within its RANSAC band of both bounds, as
// one wall seen head-on, bounds the side away from the viewpoints).
// Invalid (valid = false) for fewer than kLayoutMinPoints points or a cloud
// with no plane.
Layout FitLayout(const PointCloud& cloud,
                 const std::vector<Eigen::Vector3f>& viewpoints = {});

// Moves each face that is no plane to the wall standing past it that the
// frames saw only at their edges, too few points for a plane of the
// layout's cloud: `beyond` holds the points seen there (Layout::Beyond; the
// caller gathers them densely, at every pixel). When at least
// kSliverWallMinPoints of those past one face, and at least
// kSliverWallShare of them, lie within the band of one plane normal to its
// axis, kSliverWallGapBands or more past the face, the face moves to that
// plane, is a plane face, and takes their mean colour. No-op for an invalid
// layout.
void FitSliverWalls(const PointCloud& beyond, Layout* layout);

// Widens the faces that are no plane to hold every viewpoint with `margin`
// (world units) to spare: the cameras stood inside the scene, so its walls
// lie behind them too. No-op for an invalid layout.
void HoldViewpoints(const std::vector<Eigen::Vector3f>& viewpoints,
                    float margin, Layout* layout);

// The layout seen from a camera: z-depth (CV_32FC1, 0 where the ray misses
// the box or the layout is invalid) and colour (CV_32FC3, RGB).
void RenderLayout(const Layout& layout, const RasterCamera& camera,
                  cv::Mat* depth, cv::Mat* rgb);

// Points on the box's faces, `spacing` apart on a grid over each face
// (world units, > 0), coloured as their face: the layout as a shell of
// Gaussians. Empty for an invalid layout.
PointCloud SampleLayoutFaces(const Layout& layout, float spacing);

// Below this many points the box is not fitted: percentiles and planes of
// a few dozen points say little about a room.
inline constexpr std::size_t kLayoutMinPoints = 200;
// A sliver wall needs this many points (at every pixel: a strip of some
// 3 x 10 pixels) holding this share of those past its face: fewer, or a
// spread along the axis, are stray depth or furniture, not a wall.
inline constexpr std::size_t kSliverWallMinPoints = 32;
inline constexpr double kSliverWallShare = 0.5;
// ... and must lie at least this many bands past the face: points just past
// it are the cloud's own tail (the side of a box standing a little taller
// than the 99th percentile), not a wall.
inline constexpr float kSliverWallGapBands = 4;

}  // namespace pano4d
