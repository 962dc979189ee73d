// Any bytes as a sweep's manifest.json (first byte even) or as the status
// of its one entry (odd), then what `sweep run` and `sweep collect` read of
// them. Only pano4d::Error may come out.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "src/core/error.h"
#include "src/lab/sweep.h"

namespace {

// A manifest of one entry as `sweep plan` writes it.
const char kManifest[] = R"({"format": "pano4d-sweep", "version": 2,
  "root": "/r", "suite": "", "seeds": [0], "configs": ["default"],
  "entries": [{"index": 0, "scene": "s", "suite": "synth", "seed": 0,
  "config": "default", "workspace": "/w", "command": ["run", "--dataset",
  "/r/s", "--workspace", "/w", "--eval", "--factor", "2"]}]})";

void Write(const std::filesystem::path& file, const char* data,
           std::size_t size) {
  std::filesystem::create_directories(file.parent_path());
  std::ofstream(file, std::ios::binary | std::ios::trunc).write(data, size);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  if (size < 1) return 0;
  static const std::filesystem::path sweep =
      std::filesystem::temp_directory_path() /
      ("pano4d_sweep_fuzz_" + std::to_string(::getpid()));
  const char* body = reinterpret_cast<const char*>(data + 1);
  if (data[0] % 2 == 0) {
    Write(sweep / "manifest.json", body, size - 1);
    std::filesystem::remove(sweep / "status" / "0.json");
  } else {
    Write(sweep / "manifest.json", kManifest, sizeof(kManifest) - 1);
    Write(sweep / "status" / "0.json", body, size - 1);
  }
  try {
    const pano4d::Json m = pano4d::ReadSweepManifest(sweep);
    (void)pano4d::SweepTaskIndex(0, m["entries"].size());
    (void)pano4d::CollectSweep(sweep);
  } catch (const pano4d::Error&) {
  }
  return 0;
}
