#include "colmap_ext/colmap_commands.h"

namespace pano4d {
namespace fs = std::filesystem;

std::vector<std::string> FeatureExtractorArgs(
    const FeatureExtractorSettings& s) {
  std::vector<std::string> args = {"--database_path",
                                   s.database.string(),
                                   "--image_path",
                                   s.images.string(),
                                   "--ImageReader.camera_model",
                                   s.camera_model,
                                   "--ImageReader.single_camera",
                                   s.single_camera ? "1" : "0",
                                   "--SiftExtraction.use_gpu",
                                   "0"};
  if (!s.masks.empty())
    args.insert(args.end(), {"--ImageReader.mask_path", s.masks.string()});
  if (!s.image_list.empty())
    args.insert(args.end(), {"--image_list_path", s.image_list.string()});
  if (!s.camera_params.empty())
    args.insert(args.end(), {"--ImageReader.camera_params", s.camera_params});
  return args;
}

std::vector<std::string> MatcherArgs(const fs::path& database) {
  return {"--database_path", database.string(), "--SiftMatching.use_gpu", "0"};
}

std::vector<std::string> RelaxedMapperArgs() {
  return {"--Mapper.init_min_num_inliers",      "50",
          "--Mapper.abs_pose_min_num_inliers",  "15",
          "--Mapper.abs_pose_min_inlier_ratio", "0.15"};
}

std::vector<std::string> MapperArgs(const fs::path& database,
                                    const fs::path& images,
                                    const fs::path& output) {
  std::vector<std::string> args = {"--database_path", database.string(),
                                   "--image_path",    images.string(),
                                   "--output_path",   output.string()};
  const std::vector<std::string> relaxed = RelaxedMapperArgs();
  args.insert(args.end(), relaxed.begin(), relaxed.end());
  return args;
}

std::vector<std::string> PointTriangulatorArgs(const fs::path& database,
                                               const fs::path& images,
                                               const fs::path& input,
                                               const fs::path& output) {
  return {"--database_path",
          database.string(),
          "--image_path",
          images.string(),
          "--input_path",
          input.string(),
          "--output_path",
          output.string(),
          "--Mapper.ba_refine_focal_length",
          "0",
          "--Mapper.ba_refine_principal_point",
          "0",
          "--Mapper.ba_refine_extra_params",
          "0"};
}

std::vector<std::string> ImageUndistorterArgs(const fs::path& images,
                                              const fs::path& input,
                                              const fs::path& output) {
  return {"--image_path",  images.string(), "--input_path",  input.string(),
          "--output_path", output.string(), "--output_type", "COLMAP"};
}

}  // namespace pano4d
