// Any bytes into the .npy reader, and what it accepts into the LLFF pose
// reader (Nvidia's poses_bounds.npy). Only pano4d::Error may come out.
#include <cstddef>
#include <cstdint>

#include "src/core/error.h"
#include "src/core/npy.h"
#include "src/datasets/nvidia_dataset.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  try {
    const pano4d::NpyArray array = pano4d::ParseNpy(data, size, "fuzz.npy");
    (void)array.ToDoubles();
    (void)pano4d::LlffCameras(array, "fuzz.npy");
  } catch (const pano4d::Error&) {
  }
  return 0;
}
