#pragma once

// The expanded cameras on disk, for people and viewers: trajectories.json
// (every expanded camera with m, e, t and its source frame) and the same
// cameras as a COLMAP text model beside the training cameras, which COLMAP's
// GUI (File > Import model) shows together. `pano4d fit` and `expand` write
// them; `pano4d export`, `render` and the report read them back.

#include <filesystem>
#include <string>
#include <vector>

#include "src/pano/trajectory.h"

namespace pano4d {

// A training camera shown beside the expanded ones.
struct SourceCamera {
  std::string name;  // the frame's name; source/<name>.png in the model
  RasterCamera camera;
};

// dir/trajectories.json and dir/colmap/{cameras,images,points3D}.txt: the
// sources named source/<frame>.png, the expanded cameras
// step_<e>/dir_<m>/<frame or t>.png.
void WriteTrajectories(const std::filesystem::path& dir,
                       const std::vector<ExpandedView>& cameras,
                       const std::vector<SourceCamera>& sources);

// trajectories.json back into cameras (m, e, t, source name). Throws
// pano4d::Error naming the file and the view that is malformed.
std::vector<ExpandedView> ReadTrajectories(const std::filesystem::path& path);

}  // namespace pano4d
