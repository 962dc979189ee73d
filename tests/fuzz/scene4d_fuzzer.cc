// Any bytes as a scene4d pair (`pano4d view`'s scene): the first 4 bytes
// give the length of the JSON header, the rest is the binary. Only
// pano4d::Error may come out, and a scene that decodes is one that checks.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <string_view>

#include "src/core/error.h"
#include "src/core/json.h"
#include "src/gs/scene4d.h"
#include "src/render/bench_scene.h"

// The seed: PANO4D_FUZZ_WRITE_SEED=PATH writes a small moving scene in this
// target's input layout (scripts/fuzz.sh does this), in today's format.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  if (const char* path = std::getenv("PANO4D_FUZZ_WRITE_SEED")) {
    using namespace pano4d;
    const RasterCamera camera = BenchCamera(16, 16);
    GaussianScene scene;
    scene.statics = RandomViewFillingScene(3, camera, 3.0f, 1);
    scene.dynamics = RandomViewFillingScene(2, camera, 3.0f, 2);
    scene.num_times = 2;
    scene.bases.Reset(2, 2);
    scene.logits.assign(2 * 2, 0.0f);
    const EncodedScene4d encoded = EncodeScene4d(scene);
    const std::string header = encoded.header.dump();
    const std::uint32_t length = static_cast<std::uint32_t>(header.size());
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(&length), 4);
    out << header;
    out.write(encoded.binary.data(), encoded.binary.size());
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  if (size < 4) return 0;
  std::uint32_t length = 0;
  std::memcpy(&length, data, 4);
  length = static_cast<std::uint32_t>(std::min<std::size_t>(length, size - 4));
  const std::string_view header(reinterpret_cast<const char*>(data + 4),
                                length);
  const std::string_view binary(
      reinterpret_cast<const char*>(data + 4 + length), size - 4 - length);
  try {
    const pano4d::GaussianScene scene =
        pano4d::DecodeScene4d(pano4d::ParseJson(header, "fuzz/scene4d.json"),
                              binary, "fuzz/scene4d.json", nullptr);
    scene.Check();  // what decodes must hold together
  } catch (const pano4d::Error&) {
  }
  return 0;
}
