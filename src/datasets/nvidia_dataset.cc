#include "src/datasets/nvidia_dataset.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>

#include "src/core/error.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

fs::path SceneRoot(const fs::path& root) {
  return fs::exists(root / "dense" / "poses_bounds.npy") ? root / "dense"
                                                         : root;
}

std::vector<fs::path> SortedImages(const fs::path& dir) {
  std::vector<fs::path> images;
  if (!fs::is_directory(dir)) return images;
  for (const auto& entry : fs::directory_iterator(dir)) {
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg")
      images.push_back(entry.path());
  }
  std::sort(images.begin(), images.end());
  return images;
}

std::string Format(const char* pattern, int value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), pattern, value);
  return buffer;
}

}  // namespace

bool LooksLikeNvidia(const fs::path& root) {
  return fs::is_regular_file(SceneRoot(root) / "poses_bounds.npy");
}

std::vector<LlffCamera> LlffCameras(const NpyArray& array,
                                    const std::string& source, int width,
                                    int height) {
  if (array.shape.size() != 2 || array.shape[1] != 17 || array.shape[0] < 1) {
    std::string shape;
    for (const auto d : array.shape) {
      if (!shape.empty()) shape += " x ";
      shape += std::to_string(d);
    }
    throw Error(source, "shape", shape,
                "poses_bounds.npy must be N x 17 (LLFF)");
  }
  const std::vector<double> v = array.ToDoubles();
  std::vector<LlffCamera> cameras;
  for (std::int64_t i = 0; i < array.shape[0]; ++i) {
    const double* row = v.data() + 17 * i;
    const std::string field = "row " + std::to_string(i);
    for (int k = 0; k < 17; ++k) {
      if (!std::isfinite(row[k]))
        throw Error(source, field, std::to_string(row[k]), "not finite");
    }
    // Row-major 3x5: entry (r, c) at 5 r + c.
    const auto at = [&](int r, int c) { return row[5 * r + c]; };
    Eigen::Matrix3d world_from_cam;
    for (int r = 0; r < 3; ++r) {
      world_from_cam(r, 0) = at(r, 1);   // right
      world_from_cam(r, 1) = at(r, 0);   // down
      world_from_cam(r, 2) = -at(r, 2);  // forward = -backwards
    }
    const double error = (world_from_cam.transpose() * world_from_cam -
                          Eigen::Matrix3d::Identity())
                             .cwiseAbs()
                             .maxCoeff();
    if (error > 1e-4 || !(world_from_cam.determinant() > 0)) {
      throw Error(source, field, "|R^T R - I| = " + std::to_string(error),
                  "the pose is not a rotation in LLFF's [down, right, "
                  "backwards] order");
    }
    const Eigen::Vector3d center(at(0, 3), at(1, 3), at(2, 3));
    const double h = at(0, 4), w = at(1, 4), f = at(2, 4);
    if (!(h > 0 && w > 0 && f > 0)) {
      throw Error(source, field,
                  "hwf " + std::to_string(h) + " " + std::to_string(w) + " " +
                      std::to_string(f),
                  "image size and focal length must be positive");
    }
    const int image_w = width > 0 ? width : static_cast<int>(std::lround(w));
    const int image_h = height > 0 ? height : static_cast<int>(std::lround(h));
    const double scale = image_w / w;
    LlffCamera out;
    out.camera.camera =
        Camera{CameraModelId::kPinhole,
               image_w,
               image_h,
               {f * scale, f * scale, image_w / 2.0, image_h / 2.0}};
    const Eigen::Matrix3d cam_from_world = world_from_cam.transpose();
    const Eigen::Quaterniond rotation =
        Eigen::Quaterniond(cam_from_world).normalized();
    out.camera.cam_from_world = Rigid3d(rotation, -(rotation * center));
    out.near = row[15];
    out.far = row[16];
    cameras.push_back(out);
  }
  return cameras;
}

Dataset ReadNvidia(const fs::path& root, int factor) {
  const fs::path scene = SceneRoot(root);
  const fs::path poses_path = scene / "poses_bounds.npy";
  const NpyArray poses = ReadNpy(poses_path);
  const fs::path image_dir =
      factor > 1 &&
              fs::is_directory(scene / ("images_" + std::to_string(factor)))
          ? scene / ("images_" + std::to_string(factor))
          : scene / "images";
  const std::vector<fs::path> images = SortedImages(image_dir);

  // Image size: from the images when they are there, else hwf / factor.
  int width = 0, height = 0;
  if (!images.empty()) {
    const cv::Mat first =
        cv::imread(images.front().string(), cv::IMREAD_UNCHANGED);
    if (first.empty())
      throw Error::In(images.front().string(), "cannot be decoded as an image");
    width = first.cols;
    height = first.rows;
  } else if (poses.shape.size() == 2 && poses.shape[1] == 17 &&
             poses.shape[0] > 0) {
    const std::vector<double> v = poses.ToDoubles();
    width = static_cast<int>(std::lround(v[9] / factor));
    height = static_cast<int>(std::lround(v[4] / factor));
  }
  const std::vector<LlffCamera> cameras =
      LlffCameras(poses, poses_path.string(), width, height);
  const int n = static_cast<int>(cameras.size());
  if (!images.empty() && static_cast<int>(images.size()) != n) {
    throw Error(image_dir.string(), "images",
                std::to_string(images.size()) + " files",
                "expected one image per row of poses_bounds.npy (" +
                    std::to_string(n) + ")");
  }

  Dataset dataset;
  dataset.kind = DatasetKind::kNvidia;
  dataset.root = root;
  dataset.factor = factor;
  dataset.num_times = n;
  double near = cameras[0].near, far = cameras[0].far;
  for (int i = 0; i < n; ++i) {
    near = std::min(near, cameras[i].near);
    far = std::max(far, cameras[i].far);
    DatasetFrame frame;
    frame.camera_id = i;
    frame.time_id = i;
    frame.id = Format("%05d", i);
    frame.camera = cameras[i].camera;
    frame.rgb = images.empty() ? image_dir / (frame.id + ".png") : images[i];
    dataset.train.push_back(frame);

    DatasetFrame test;
    test.camera_id = 0;
    test.time_id = i;
    test.id = Format("v000_t%03d", i);
    test.camera = cameras[0].camera;
    const fs::path nsff = scene / "mv_images" / Format("%05d", i) / "cam01.jpg";
    const fs::path dynamic_nerf = scene / "gt" / (test.id + ".png");
    test.rgb = fs::exists(nsff) ? nsff : dynamic_nerf;
    dataset.val.push_back(test);
  }
  dataset.near = near;
  dataset.far = far;
  return dataset;
}

}  // namespace pano4d
