#include "src/core/check.h"

#include <filesystem>

namespace pano4d::internal {

void CheckFailed(const char* condition, const char* file, int line,
                 const std::string& message) {
  throw InternalError(
      "a bug in pano4d, not in your input: " + message + " (" +
      std::filesystem::path(file).filename().string() + ":" +
      std::to_string(line) + ", `" + condition +
      "` failed); please report it with the command that led here");
}

}  // namespace pano4d::internal
