#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

#include "src/core/camera.h"
#include "src/core/posed_camera.h"
#include "src/core/rigid.h"

namespace pano4d {

// A COLMAP sparse model (cameras, images, points3D) as COLMAP 3.8 stores it,
// field for field, so that reading a file and writing it back gives the same
// bytes. The readers and writers are in model_io_binary.h and
// model_io_text.h; ReadModel/WriteModel below handle a whole folder.

// COLMAP's id for "this 2D point has no 3D point"; text files write it as -1.
inline constexpr std::uint64_t kInvalidPoint3DId =
    std::numeric_limits<std::uint64_t>::max();

struct ColmapCamera {
  std::uint32_t camera_id = 0;
  // COLMAP's model id (CameraModelId in src/core/camera.h). The readers refuse
  // ids COLMAP 3.8 does not define, since the parameter count depends on it.
  int model_id = static_cast<int>(CameraModelId::kPinhole);
  std::uint64_t width = 0;
  std::uint64_t height = 0;
  std::vector<double> params;  // COLMAP's order for model_id
};

struct ColmapPoint2D {
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();  // pixels, COLMAP convention
  std::uint64_t point3D_id = kInvalidPoint3DId;

  bool HasPoint3D() const { return point3D_id != kInvalidPoint3DId; }
};

struct ColmapImage {
  std::uint32_t image_id = 0;
  // World-to-camera rotation (w, x, y, z) and translation, exactly as stored:
  // pano4d does not renormalize. COLMAP divides qvec by its norm when it reads
  // and again when it writes, which can move the last bit of a qvec that is
  // not exactly unit, so byte equality with COLMAP's output needs unit qvecs.
  Eigen::Vector4d qvec = Eigen::Vector4d(1.0, 0.0, 0.0, 0.0);
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();
  std::uint32_t camera_id = 0;
  std::string name;
  std::vector<ColmapPoint2D> points2D;

  // The pose, qvec normalized. Throws pano4d::Error naming `source` and this
  // image for a zero or non-finite qvec or a non-finite tvec.
  Rigid3d CamFromWorld(const std::string& source = "COLMAP model") const;
  void SetCamFromWorld(const Rigid3d& cam_from_world);
  // The camera centre in world coordinates, -R^T t.
  Eigen::Vector3d Center(const std::string& source = "COLMAP model") const;
  // Points2D with a 3D point: COLMAP's observations of this image.
  std::size_t NumPoints3D() const;
};

struct ColmapTrackElement {
  std::uint32_t image_id = 0;
  std::uint32_t point2D_idx = 0;  // index into that image's points2D

  bool operator==(const ColmapTrackElement&) const = default;
};

struct ColmapPoint3D {
  std::uint64_t point3D_id = 0;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  std::array<std::uint8_t, 3> rgb = {0, 0, 0};
  double error = 0.0;  // mean reprojection error, pixels
  std::vector<ColmapTrackElement> track;
};

// COLMAP's summary numbers, as `colmap model_analyzer` prints them. Every
// image of a COLMAP 3.8 model file is registered (COLMAP writes registered
// images only), so registered_images == images. An observation is a point2D
// with a 3D point id; in a model that passes Check() that is also the sum of
// the track lengths.
struct ColmapModelStats {
  std::size_t cameras = 0;
  std::size_t images = 0;
  std::size_t registered_images = 0;
  std::size_t points3D = 0;
  std::size_t observations = 0;
  double mean_track_length = 0.0;            // observations / points3D, or 0
  double mean_observations_per_image = 0.0;  // observations / images, or 0
};

struct ColmapModel {
  // In file order: COLMAP writes in the iteration order of its hash maps, and
  // keeping that order is what makes read -> write reproduce the bytes.
  std::vector<ColmapCamera> cameras;
  std::vector<ColmapImage> images;
  std::vector<ColmapPoint3D> points3D;

  // Lookups by id (the first entry with that id); nullptr when absent. They
  // are O(1) while the index is current and fall back to a scan otherwise, so
  // they are never wrong: the readers build the index, callers that edit the
  // lists call BuildIndex() again to keep lookups fast.
  void BuildIndex();
  const ColmapCamera* FindCamera(std::uint32_t camera_id) const;
  const ColmapImage* FindImage(std::uint32_t image_id) const;
  const ColmapImage* FindImageByName(std::string_view name) const;
  const ColmapPoint3D* FindPoint3D(std::uint64_t point3D_id) const;

  // Throws pano4d::Error naming `source` and the offending id when ids repeat,
  // a camera has an unknown model or the wrong number of parameters, an image
  // refers to a missing camera or 3D point, or a track element refers to a
  // missing image or point2D, or to a point2D that does not refer back to its
  // 3D point (each observation must be listed exactly once in its track).
  void Check(const std::string& source = "COLMAP model") const;

  // Points2D with a 3D point over all images (COLMAP's observation count).
  std::size_t NumObservations() const;
  double MeanTrackLength() const;
  double MeanObservationsPerImage() const;
  ColmapModelStats Stats() const;

  // The camera and pose of `image`, as pano4d's types; throws pano4d::Error
  // naming `source` when the camera is missing or fails Camera::Check().
  PosedCamera PosedCameraOf(const ColmapImage& image,
                            const std::string& source = "COLMAP model") const;

 private:
  std::unordered_map<std::uint32_t, std::size_t> camera_index_;
  std::unordered_map<std::uint32_t, std::size_t> image_index_;
  std::unordered_map<std::string, std::size_t> image_name_index_;
  std::unordered_map<std::uint64_t, std::size_t> point3D_index_;
};

// The model of `camera`; throws pano4d::Error naming `source` and the camera
// when COLMAP 3.8 does not define its model id or its parameter count does
// not match the model.
const CameraModelInfo& CheckedCameraModel(const ColmapCamera& camera,
                                          const std::string& source);

// Conversions to and from pano4d's Camera. ToCamera throws pano4d::Error
// naming `source` and the camera id for an unknown model, a size beyond int,
// or anything Camera::Check() refuses.
Camera ToCamera(const ColmapCamera& camera,
                const std::string& source = "COLMAP model");
ColmapCamera FromCamera(std::uint32_t camera_id, const Camera& camera);

// Whole sparse folders: cameras, images and points3D with .bin or .txt.
enum class ColmapFormat { kBinary, kText };
std::string_view ToString(ColmapFormat format);

// The format of the complete set of three files in `dir`, preferring binary
// when both are complete (as COLMAP does); nullopt when neither is.
std::optional<ColmapFormat> DetectModelFormat(const std::filesystem::path& dir);

// Reads the model in `dir` (format detected as above) and builds its index;
// does not Check() it. Files that newer COLMAP versions write beside the
// three (rigs, frames) are ignored with one log line: images.bin/txt still
// hold every image's pose there. Throws pano4d::Error naming the folder
// when no complete set exists, or the file and field when one is malformed.
ColmapModel ReadModel(const std::filesystem::path& dir);

// Writes the three files of `format` into `dir` (created if missing), each
// atomically. Logs a warning when `dir` still holds a complete set in the
// other format, since a binary set would shadow a text one on reading.
void WriteModel(const ColmapModel& model, const std::filesystem::path& dir,
                ColmapFormat format);

}  // namespace pano4d
