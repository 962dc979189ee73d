#include "colmap_ext/model.h"

#include <climits>
#include <cmath>
#include <fstream>
#include <sstream>
#include <unordered_set>

#include "colmap_ext/model_file.h"
#include "colmap_ext/model_io_binary.h"
#include "colmap_ext/model_io_text.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/log.h"

namespace pano4d {
namespace {

std::string Id(std::uint64_t id) { return std::to_string(id); }

std::string PointIdText(std::uint64_t id) {
  return id == kInvalidPoint3DId ? std::string("-1") : Id(id);
}

std::string QvecText(const Eigen::Vector4d& q) {
  std::ostringstream text;
  text.precision(17);
  text << "(" << q(0) << ", " << q(1) << ", " << q(2) << ", " << q(3) << ")";
  return text.str();
}

// Index lookups validate the hit, so a stale index costs a scan, never a
// wrong answer.
template <typename T, typename Key, typename GetKey>
const T* Find(const std::vector<T>& list,
              const std::unordered_map<Key, std::size_t>& index, const Key& key,
              const GetKey& get_key) {
  const auto it = index.find(key);
  if (it != index.end() && it->second < list.size() &&
      get_key(list[it->second]) == key) {
    // A later edit may have put an entry with this key before the indexed
    // one; the index is only trusted for the first occurrence it recorded.
    if (index.size() == list.size()) return &list[it->second];
  }
  for (const T& item : list) {
    if (get_key(item) == key) return &item;
  }
  return nullptr;
}

template <typename T, typename Key, typename GetKey>
void Index(const std::vector<T>& list,
           std::unordered_map<Key, std::size_t>& index, const GetKey& get_key) {
  index.clear();
  index.reserve(list.size());
  for (std::size_t i = 0; i < list.size(); ++i) {
    index.emplace(get_key(list[i]), i);  // keeps the first of repeated ids
  }
}

void CheckCameras(const ColmapModel& model, const std::string& source) {
  std::unordered_set<std::uint32_t> ids;
  for (const ColmapCamera& camera : model.cameras) {
    const std::string name = "camera " + Id(camera.camera_id);
    if (!ids.insert(camera.camera_id).second) {
      throw Error(source, name, "", "camera id appears more than once");
    }
    CheckedCameraModel(camera, source);
  }
}

}  // namespace

Rigid3d ColmapImage::CamFromWorld(const std::string& source) const {
  if (!qvec.allFinite() || !(qvec.cwiseAbs().maxCoeff() > 0)) {
    throw Error(source, "image " + Id(image_id) + " qvec", QvecText(qvec),
                "must be a finite, non-zero quaternion");
  }
  if (!tvec.allFinite()) {
    throw Error(source, "image " + Id(image_id) + " tvec", "",
                "must be finite");
  }
  return Rigid3d::FromColmap(qvec, tvec);
}

void ColmapImage::SetCamFromWorld(const Rigid3d& cam_from_world) {
  qvec = cam_from_world.ColmapQvec();
  tvec = cam_from_world.translation;
}

Eigen::Vector3d ColmapImage::Center(const std::string& source) const {
  return CameraCenter(CamFromWorld(source));
}

std::size_t ColmapImage::NumPoints3D() const {
  std::size_t count = 0;
  for (const ColmapPoint2D& point : points2D) count += point.HasPoint3D();
  return count;
}

void ColmapModel::BuildIndex() {
  Index(cameras, camera_index_,
        [](const ColmapCamera& c) { return c.camera_id; });
  Index(images, image_index_, [](const ColmapImage& i) { return i.image_id; });
  Index(images, image_name_index_, [](const ColmapImage& i) { return i.name; });
  Index(points3D, point3D_index_,
        [](const ColmapPoint3D& p) { return p.point3D_id; });
}

const ColmapCamera* ColmapModel::FindCamera(std::uint32_t camera_id) const {
  return Find(cameras, camera_index_, camera_id,
              [](const ColmapCamera& c) { return c.camera_id; });
}

const ColmapImage* ColmapModel::FindImage(std::uint32_t image_id) const {
  return Find(images, image_index_, image_id,
              [](const ColmapImage& i) { return i.image_id; });
}

const ColmapImage* ColmapModel::FindImageByName(std::string_view name) const {
  return Find(
      images, image_name_index_, std::string(name),
      [](const ColmapImage& i) -> const std::string& { return i.name; });
}

const ColmapPoint3D* ColmapModel::FindPoint3D(std::uint64_t point3D_id) const {
  return Find(points3D, point3D_index_, point3D_id,
              [](const ColmapPoint3D& p) { return p.point3D_id; });
}

namespace {

// Each point3D id's index; the invalid id and repeated ids are refused.
std::unordered_map<std::uint64_t, std::size_t> IndexPoints(
    const ColmapModel& m, const std::string& source) {
  std::unordered_map<std::uint64_t, std::size_t> point_index;
  point_index.reserve(m.points3D.size());
  for (std::size_t i = 0; i < m.points3D.size(); ++i) {
    const std::uint64_t id = m.points3D[i].point3D_id;
    if (id == kInvalidPoint3DId) {
      throw Error(source, "point3D " + Id(id), "",
                  "this id is COLMAP's marker for 'no 3D point'");
    }
    if (!point_index.emplace(id, i).second) {
      throw Error(source, "point3D " + Id(id), "",
                  "point3D id appears more than once");
    }
  }
  return point_index;
}

// Each image id's index, its camera and its points2D's point3D ids checked;
// first_slot[i] is image i's first point2D in one flat numbering, so that
// each observation can be matched with exactly one track element.
std::unordered_map<std::uint32_t, std::size_t> IndexImages(
    const ColmapModel& m,
    const std::unordered_map<std::uint64_t, std::size_t>& point_index,
    const std::string& source, std::vector<std::size_t>* first_slot) {
  std::unordered_map<std::uint32_t, std::size_t> image_index;
  first_slot->assign(m.images.size() + 1, 0);
  std::unordered_set<std::uint32_t> camera_ids;
  for (const ColmapCamera& camera : m.cameras)
    camera_ids.insert(camera.camera_id);
  for (std::size_t i = 0; i < m.images.size(); ++i) {
    const ColmapImage& image = m.images[i];
    const std::string name = "image " + Id(image.image_id);
    if (!image_index.emplace(image.image_id, i).second) {
      throw Error(source, name, "", "image id appears more than once");
    }
    if (!camera_ids.count(image.camera_id)) {
      throw Error(source, name + " camera_id", Id(image.camera_id),
                  "no camera has this id");
    }
    for (std::size_t j = 0; j < image.points2D.size(); ++j) {
      const std::uint64_t id = image.points2D[j].point3D_id;
      if (id != kInvalidPoint3DId && !point_index.count(id)) {
        throw Error(source, name + " point2D " + Id(j) + " point3D_id", Id(id),
                    "no 3D point has this id");
      }
    }
    (*first_slot)[i + 1] = (*first_slot)[i] + image.points2D.size();
  }
  return image_index;
}

// Every track element names an existing point2D that refers back to its
// point, once; marks those point2Ds in `listed` and returns their count.
std::size_t CheckTracks(
    const ColmapModel& m,
    const std::unordered_map<std::uint32_t, std::size_t>& image_index,
    const std::vector<std::size_t>& first_slot, const std::string& source,
    std::vector<bool>* listed) {
  std::size_t track_elements = 0;
  for (const ColmapPoint3D& point : m.points3D) {
    const std::string name = "point3D " + Id(point.point3D_id);
    for (std::size_t k = 0; k < point.track.size(); ++k) {
      const ColmapTrackElement& element = point.track[k];
      const std::string field = name + " track element " + Id(k);
      const auto it = image_index.find(element.image_id);
      if (it == image_index.end()) {
        throw Error(source, field + " image_id", Id(element.image_id),
                    "no image has this id");
      }
      const ColmapImage& image = m.images[it->second];
      if (element.point2D_idx >= image.points2D.size()) {
        throw Error(source, field + " point2D_idx", Id(element.point2D_idx),
                    "image " + Id(image.image_id) + " has " +
                        Id(image.points2D.size()) + " points2D");
      }
      const std::uint64_t back = image.points2D[element.point2D_idx].point3D_id;
      if (back != point.point3D_id) {
        throw Error(source, field, "",
                    "image " + Id(image.image_id) + " point2D " +
                        Id(element.point2D_idx) + " refers to point3D " +
                        PointIdText(back) + ", not to this point");
      }
      const std::size_t slot = first_slot[it->second] + element.point2D_idx;
      if ((*listed)[slot]) {
        throw Error(source, field, "",
                    "image " + Id(image.image_id) + " point2D " +
                        Id(element.point2D_idx) +
                        " is listed twice in this track");
      }
      (*listed)[slot] = true;
      ++track_elements;
    }
  }
  return track_elements;
}

}  // namespace

void ColmapModel::Check(const std::string& source) const {
  CheckCameras(*this, source);
  const std::unordered_map<std::uint64_t, std::size_t> point_index =
      IndexPoints(*this, source);
  std::vector<std::size_t> first_slot;
  const std::unordered_map<std::uint32_t, std::size_t> image_index =
      IndexImages(*this, point_index, source, &first_slot);
  std::vector<bool> listed(first_slot.back(), false);
  if (CheckTracks(*this, image_index, first_slot, source, &listed) ==
      NumObservations())
    return;
  // An observation no track lists: name the first.
  for (std::size_t i = 0; i < images.size(); ++i) {
    const ColmapImage& image = images[i];
    for (std::size_t j = 0; j < image.points2D.size(); ++j) {
      if (image.points2D[j].HasPoint3D() && !listed[first_slot[i] + j]) {
        throw Error(
            source,
            "image " + Id(image.image_id) + " point2D " + Id(j) + " point3D_id",
            Id(image.points2D[j].point3D_id),
            "the track of that point does not list this point2D");
      }
    }
  }
}

std::size_t ColmapModel::NumObservations() const {
  std::size_t count = 0;
  for (const ColmapImage& image : images) count += image.NumPoints3D();
  return count;
}

// COLMAP divides the same way (observations as size_t over a double count),
// so the text headers print the same digits.
double ColmapModel::MeanTrackLength() const {
  if (points3D.empty()) return 0.0;
  return static_cast<double>(NumObservations()) /
         static_cast<double>(points3D.size());
}

double ColmapModel::MeanObservationsPerImage() const {
  if (images.empty()) return 0.0;
  return static_cast<double>(NumObservations()) /
         static_cast<double>(images.size());
}

ColmapModelStats ColmapModel::Stats() const {
  ColmapModelStats stats;
  stats.cameras = cameras.size();
  stats.images = images.size();
  stats.registered_images = images.size();
  stats.points3D = points3D.size();
  stats.observations = NumObservations();
  stats.mean_track_length = MeanTrackLength();
  stats.mean_observations_per_image = MeanObservationsPerImage();
  return stats;
}

PosedCamera ColmapModel::PosedCameraOf(const ColmapImage& image,
                                       const std::string& source) const {
  const ColmapCamera* camera = FindCamera(image.camera_id);
  if (camera == nullptr) {
    throw Error(source, "image " + Id(image.image_id) + " camera_id",
                Id(image.camera_id), "no camera has this id");
  }
  return PosedCamera{ToCamera(*camera, source), image.CamFromWorld(source)};
}

const CameraModelInfo& CheckedCameraModel(const ColmapCamera& camera,
                                          const std::string& source) {
  const std::optional<CameraModelId> id = CameraModelFromId(camera.model_id);
  if (!id) {
    throw Error(source, "camera " + Id(camera.camera_id) + " model_id",
                std::to_string(camera.model_id),
                "not a COLMAP 3.8 camera model id (0 to 10)");
  }
  const CameraModelInfo& info = GetCameraModelInfo(*id);
  if (camera.params.size() != static_cast<std::size_t>(info.num_params)) {
    throw Error(source, "camera " + Id(camera.camera_id) + " params",
                Id(camera.params.size()) + " values",
                std::string(info.name) + " takes " + Id(info.num_params));
  }
  return info;
}

Camera ToCamera(const ColmapCamera& camera, const std::string& source) {
  const std::string name = "camera " + Id(camera.camera_id);
  const CameraModelInfo& info = CheckedCameraModel(camera, source);
  if (camera.width > INT_MAX || camera.height > INT_MAX) {
    throw Error(source, name, Id(camera.width) + " x " + Id(camera.height),
                "image size beyond what pano4d handles (2^31 - 1)");
  }
  Camera result;
  result.model_id = info.id;
  result.width = static_cast<int>(camera.width);
  result.height = static_cast<int>(camera.height);
  result.params = camera.params;
  result.Check(source + ": " + name);
  return result;
}

ColmapCamera FromCamera(std::uint32_t camera_id, const Camera& camera) {
  ColmapCamera result;
  result.camera_id = camera_id;
  result.model_id = static_cast<int>(camera.model_id);
  result.width = static_cast<std::uint64_t>(camera.width);
  result.height = static_cast<std::uint64_t>(camera.height);
  result.params = camera.params;
  return result;
}

std::string_view ToString(ColmapFormat format) {
  return format == ColmapFormat::kBinary ? "binary" : "text";
}

namespace {

constexpr const char* kModelFiles[] = {"cameras", "images", "points3D"};

std::string Extension(ColmapFormat format) {
  return format == ColmapFormat::kBinary ? ".bin" : ".txt";
}

bool HasCompleteSet(const std::filesystem::path& dir, ColmapFormat format) {
  for (const char* file : kModelFiles) {
    std::error_code error;
    if (!std::filesystem::is_regular_file(dir / (file + Extension(format)),
                                          error)) {
      return false;
    }
  }
  return true;
}

}  // namespace

std::optional<ColmapFormat> DetectModelFormat(
    const std::filesystem::path& dir) {
  if (HasCompleteSet(dir, ColmapFormat::kBinary)) return ColmapFormat::kBinary;
  if (HasCompleteSet(dir, ColmapFormat::kText)) return ColmapFormat::kText;
  return std::nullopt;
}

ColmapModel ReadModel(const std::filesystem::path& dir) {
  const std::optional<ColmapFormat> format = DetectModelFormat(dir);
  if (!format) {
    throw Error::In(dir.string(),
                    "no COLMAP model: expected cameras, images and points3D, "
                    "all three .bin or all three .txt");
  }
  ColmapModel model;
  if (*format == ColmapFormat::kBinary) {
    ReadCamerasBinary(model, dir / "cameras.bin");
    ReadImagesBinary(model, dir / "images.bin");
    ReadPoints3DBinary(model, dir / "points3D.bin");
  } else {
    ReadCamerasText(model, dir / "cameras.txt");
    ReadImagesText(model, dir / "images.txt");
    ReadPoints3DText(model, dir / "points3D.txt");
  }
  model.BuildIndex();
  // Repeated ids and references to missing cameras, points or images: said
  // once, as a warning, since pano4d reads each image's pose and the 3D
  // points as they are (and ToCamera still refuses a missing camera).
  try {
    model.Check(dir.string());
  } catch (const Error& e) {
    PANO4D_LOG(kWarning) << e.what()
                         << " (the model is used as it is; COLMAP's "
                            "model_converter or a fresh `pano4d sfm` writes a "
                            "consistent one)";
  }

  // COLMAP 3.12+ adds rigs and frames; its images files still hold each
  // image's cam_from_world, which is all pano4d uses.
  std::string ignored;
  for (const char* name : {"rigs", "frames"}) {
    const std::string file = name + Extension(*format);
    std::error_code error;
    if (std::filesystem::exists(dir / file, error)) {
      ignored += (ignored.empty() ? "" : ", ") + file;
    }
  }
  if (!ignored.empty()) {
    PANO4D_LOG(kInfo) << dir.string() << ": ignored " << ignored
                      << " (newer COLMAP rig data; poses come from images"
                      << Extension(*format) << ")";
  }
  return model;
}

void WriteModel(const ColmapModel& model, const std::filesystem::path& dir,
                ColmapFormat format) {
  EnsureDirectory(dir);
  if (format == ColmapFormat::kBinary) {
    WriteCamerasBinary(model, dir / "cameras.bin");
    WriteImagesBinary(model, dir / "images.bin");
    WritePoints3DBinary(model, dir / "points3D.bin");
  } else {
    WriteCamerasText(model, dir / "cameras.txt");
    WriteImagesText(model, dir / "images.txt");
    WritePoints3DText(model, dir / "points3D.txt");
    if (HasCompleteSet(dir, ColmapFormat::kBinary)) {
      PANO4D_LOG(kWarning)
          << dir.string()
          << ": also holds cameras/images/points3D.bin, which readers (COLMAP "
             "and pano4d) prefer over the .txt files just written";
    }
  }
}

void ReadModelFile(
    const std::filesystem::path& path,
    const std::function<void(std::istream&, const std::string&)>& read) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) {
    throw Error::In(path.string(), "is a directory, not a model file");
  }
  std::ifstream file(path, std::ios::binary);
  if (!file) throw Error::In(path.string(), "cannot open the file");
  read(file, path.string());
}

void WriteModelFile(const std::filesystem::path& path,
                    const std::function<void(std::ostream&)>& write) {
  WriteAtomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream file(tmp, std::ios::binary | std::ios::trunc);
    if (!file) throw Error::In(tmp.string(), "cannot open for writing");
    try {
      write(file);
    } catch (const Error& error) {
      throw Error(path.string(), error.field(), error.value(), error.problem());
    }
    file.close();
    if (!file) throw Error::In(tmp.string(), "writing failed");
  });
}

}  // namespace pano4d
