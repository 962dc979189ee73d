// Any bytes into the JSON parser, and what parses into the camera loaders
// (DyCheck's camera/<id>.json and pano4d's camera JSON) and DyCheck's split
// reader (splits/<name>.json, then its time ids made dense). Only
// pano4d::Error may come out.
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "src/core/camera.h"
#include "src/core/error.h"
#include "src/core/json.h"
#include "src/datasets/dycheck_camera.h"
#include "src/datasets/dycheck_dataset.h"

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
  try {
    std::vector<pano4d::DatasetFrame> frames;
    for (const pano4d::DyCheckSplitEntry& e :
         pano4d::ParseDyCheckSplit(json, "fuzz.json")) {
      frames.emplace_back();
      frames.back().id = e.id;
      frames.back().time_id = e.time_id;
    }
    std::vector<pano4d::DatasetFrame*> pointers;
    for (pano4d::DatasetFrame& f : frames) pointers.push_back(&f);
    const int times = pano4d::MakeTimeIdsDense(pointers, "fuzz.json");
    for (const pano4d::DatasetFrame& f : frames) {
      if (f.time_id < 0 || f.time_id >= times) __builtin_trap();
    }
  } catch (const pano4d::Error&) {
  }
  return 0;
}
