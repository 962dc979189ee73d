// Any bytes as a workspace's frames.json (a file shared between people and
// machines): only pano4d::Error may come out, and no frame read may name a
// path outside the workspace.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "src/core/error.h"
#include "src/core/frames.h"
#include "src/core/workspace.h"

namespace {

std::filesystem::path Workspace() {
  static const std::filesystem::path ws =
      std::filesystem::temp_directory_path() /
      ("pano4d_frames_fuzz_" + std::to_string(::getpid()));
  return ws;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  const std::filesystem::path file =
      pano4d::Workspace(Workspace()).frames_json();
  std::filesystem::create_directories(file.parent_path());
  std::ofstream(file, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), size);
  try {
    const pano4d::WorkspaceFrames frames =
        pano4d::ReadWorkspaceFrames(Workspace());
    for (const auto* split : {&frames.train, &frames.val})
      for (const pano4d::WorkspaceFrame& f : *split)
        if (f.name.find('/') != std::string::npos || f.name == "..")
          std::abort();  // a name that would write outside the workspace
  } catch (const pano4d::Error&) {
  }
  return 0;
}
