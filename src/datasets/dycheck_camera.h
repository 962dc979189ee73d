#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "src/core/posed_camera.h"

namespace pano4d {

// DyCheck's (and Nerfies') camera/<id>.json:
//   orientation  3x3 world-to-camera rotation (rows), OpenCV axes
//   position     camera centre in world coordinates
//   focal_length, pixel_aspect_ratio (fy = focal * aspect), skew,
//   principal_point [cx, cy], image_size [W, H],
//   radial_distortion [k1, k2, k3], tangential_distortion [p1, p2]
// Pixel centres are at +0.5 as in COLMAP, so the parameters carry over
// unchanged. The intrinsics become the simplest COLMAP model that represents
// them exactly: PINHOLE without distortion, OPENCV when k3 = 0, FULL_OPENCV
// otherwise (its rational radial term with k4 = k5 = k6 = 0 is DyCheck's
// polynomial). A non-zero skew has no COLMAP model and is an error.
PosedCamera DyCheckCameraFromJson(const nlohmann::json& json,
                                  const std::string& source);
// The inverse; throws pano4d::Error for models DyCheck cannot express
// (fisheye, FOV, rational radial terms).
nlohmann::json DyCheckCameraToJson(const PosedCamera& camera);

PosedCamera ReadDyCheckCamera(const std::filesystem::path& path);
void WriteDyCheckCamera(const std::filesystem::path& path,
                        const PosedCamera& camera);

// How far an orientation matrix may be from a rotation, per entry of
// R^T R - I: DyCheck stores float32 values (worst seen: 8e-8); anything
// beyond this is a corrupt file, not rounding.
inline constexpr double kMaxOrientationError = 1e-5;

}  // namespace pano4d
