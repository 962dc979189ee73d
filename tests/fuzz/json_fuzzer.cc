// Any bytes into the JSON parser, and what parses into the camera loaders
// (DyCheck's camera/<id>.json and pano4d's camera JSON). Only pano4d::Error
// may come out.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "src/core/camera.h"
#include "src/core/error.h"
#include "src/core/json.h"
#include "src/datasets/dycheck_camera.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  pano4d::Json json;
  try {
    json = pano4d::ParseJson(
        std::string_view(reinterpret_cast<const char*>(data), size),
        "fuzz.json");
  } catch (const pano4d::Error&) {
    return 0;
  }
  try {
    (void)pano4d::DyCheckCameraFromJson(json, "fuzz.json");
  } catch (const pano4d::Error&) {
  }
  try {
    (void)pano4d::CameraFromJson(json, "fuzz.json");
  } catch (const pano4d::Error&) {
  }
  return 0;
}
