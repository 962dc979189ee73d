#include "colmap_ext/masks.h"

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/strings.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

void WriteMasks(const std::vector<cv::Mat>& masks,
                const std::vector<std::string>& image_names,
                const fs::path& dir, bool invert) {
  if (masks.size() != image_names.size()) {
    throw Error(dir.string(), "image_names",
                std::to_string(image_names.size()) + " names",
                "expected one per mask (" + std::to_string(masks.size()) + ")");
  }
  // Everything is checked before the first file is written.
  std::vector<fs::path> paths;
  for (std::size_t i = 0; i < masks.size(); ++i) {
    const std::string source =
        "mask " + std::to_string(i) + " (" + image_names[i] + ")";
    if (masks[i].empty() || masks[i].type() != CV_8UC1) {
      throw Error(source, "type", std::to_string(masks[i].type()),
                  "expected a non-empty CV_8UC1 mask");
    }
    if (masks[i].size() != masks[0].size()) {
      throw Error(source, "size", SizeText(masks[i].cols, masks[i].rows),
                  "expected " + SizeText(masks[0].cols, masks[0].rows) +
                      " like mask 0");
    }
    paths.push_back(MaskPathFor(dir, image_names[i]));
  }
  for (std::size_t i = 0; i < masks.size(); ++i) {
    // Anything nonzero is dynamic; the files hold 0 and 255 only.
    WriteMask(paths[i], invert ? (masks[i] == 0) : (masks[i] != 0));
  }
}

}  // namespace

fs::path MaskPathFor(const fs::path& dir, const std::string& image_name) {
  const fs::path name(image_name);
  bool climbs = false;
  for (const fs::path& part : name) climbs = climbs || part == "..";
  if (image_name.empty() || name.is_absolute() || climbs) {
    throw Error("image name", "", "\"" + image_name + "\"",
                "expected a relative name inside the image folder, as in "
                "COLMAP's database");
  }
  return dir / (image_name + ".png");
}

void WriteColmapMasks(const std::vector<cv::Mat>& masks,
                      const std::vector<std::string>& image_names,
                      const fs::path& dir) {
  WriteMasks(masks, image_names, dir, /*invert=*/true);
}

void WriteDynamicMasks(const std::vector<cv::Mat>& masks,
                       const std::vector<std::string>& image_names,
                       const fs::path& dir) {
  WriteMasks(masks, image_names, dir, /*invert=*/false);
}

}  // namespace pano4d
