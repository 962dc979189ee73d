#pragma once

// Mask files beside a COLMAP workspace: named as COLMAP's
// --ImageReader.mask_path expects (images/abc.jpg -> masks/abc.jpg.png),
// written in COLMAP's convention (0 = no features) or in pano4d's (255 =
// moving).

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace pano4d {

// Where the mask of image `image_name` (relative, as in COLMAP's database,
// e.g. "abc.jpg" or "cam1/abc.jpg") lies in `dir`: COLMAP's rule,
// dir/abc.jpg.png. Throws pano4d::Error for an absolute name or one with "..".
std::filesystem::path MaskPathFor(const std::filesystem::path& dir,
                                  const std::string& image_name);

// Masks for COLMAP's --ImageReader.mask_path: COLMAP extracts no features
// where its mask is 0, so a dynamic pixel is written as 0 and a static one
// as 255 (the inverse of the in-memory mask). Atomic writes, at MaskPathFor.
void WriteColmapMasks(const std::vector<cv::Mat>& masks,
                      const std::vector<std::string>& image_names,
                      const std::filesystem::path& dir);
// The same masks as they are in memory (255 = dynamic), for pano4d's own
// stages (ws/pano4d/tracks/dynamic/), at MaskPathFor.
void WriteDynamicMasks(const std::vector<cv::Mat>& masks,
                       const std::vector<std::string>& image_names,
                       const std::filesystem::path& dir);

}  // namespace pano4d
