// Any bytes as a camera file (`render --trajectory FILE`) and as an
// expansion's trajectories.json: only pano4d::Error may come out.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "src/core/error.h"
#include "src/pano/trajectory.h"
#include "src/pano/trajectory_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  static const std::filesystem::path file =
      std::filesystem::temp_directory_path() /
      ("pano4d_trajectory_fuzz_" + std::to_string(::getpid()) + ".json");
  std::ofstream(file, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), size);
  try {
    (void)pano4d::ReadCameraFile(file.string());
  } catch (const pano4d::Error&) {
  }
  try {
    (void)pano4d::ReadTrajectories(file);
  } catch (const pano4d::Error&) {
  }
  return 0;
}
