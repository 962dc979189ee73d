#pragma once

// Depth maps on disk, whatever tool or dataset wrote them, as pano4d's
// z-depth in memory: CV_32F, 0 = no depth.

#include <filesystem>

#include <opencv2/core.hpp>

#include "src/core/camera.h"
#include "src/datasets/dataset.h"

namespace pano4d {

// A depth map file: .npy (H x W or H x W x 1) or an image OpenCV reads
// unchanged (16-bit PNG in millimetres, float TIFF or EXR). Non-finite,
// negative and implausibly far values become 0. Throws pano4d::Error naming the
// file when it is none of these.
cv::Mat ReadDepthMap(const std::filesystem::path& path);

// The largest depth a map may hold: a million scene units (1000 km in
// metres) is no surface of a capture; such values are a renderer's
// background (Blender's Z pass: 1e10) or a broken conversion (1e30), which
// would otherwise reach the initialisation's k-means as an OpenCV error.
// ReadDepthMap takes them as no depth, with a warning naming the file.
inline constexpr double kMaxPlausibleDepth = 1e6;

// A dataset frame's z-depth (its file by the dataset's convention), of its
// camera's size. Throws pano4d::Error naming the file when the size differs.
cv::Mat ReadDepth(const DatasetFrame& frame);

// Distances along each pixel's ray (x_n, y_n, 1) of a pinhole `camera` to
// z-depth: z = distance / |ray|.
void RayDistanceToZ(const Camera& camera, cv::Mat* depth);

// `depth` (CV_32F) as an H x W float32 .npy, atomically.
void WriteDepthMap(const std::filesystem::path& path, const cv::Mat& depth);

}  // namespace pano4d
