#pragma once

// Stage stamps: the options a stage ran with and the files it read (size
// and modification time), written once the stage completed and removed when
// it starts again, so that a later run reuses a stage only when nothing it
// read changed, and says why it runs one again.

#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "src/core/workspace.h"

namespace pano4d {

// A stage's inputs as its stamp records them.
class StageInputs {
 public:
  // Files under `root` (the workspace) are recorded relative to it, so a
  // workspace copied with its modification times keeps its stamps.
  explicit StageInputs(std::filesystem::path root) : root_(std::move(root)) {}

  StageInputs& Option(const std::string& key, nlohmann::json value);
  // A file's size and modification time; a folder's: every regular file
  // under it (following links to folders; the workspace and its pano4d/
  // are left out); a path that does not exist is recorded as missing.
  StageInputs& File(const std::filesystem::path& path);

  const nlohmann::json& json() const { return json_; }

 private:
  std::filesystem::path root_;
  nlohmann::json json_ = {{"options", nlohmann::json::object()},
                          {"files", nlohmann::json::object()}};
};

// Why a stage that completed with `stamped` inputs must run again for
// `now`: the first option or file that differs, said for a person
// ("option factor was 2, now 1", "images/0003.png changed", "depth/x.npy is
// new"); nullopt when they are the same.
std::optional<std::string> InputsDifference(const nlohmann::json& stamped,
                                            const nlohmann::json& now);

// One stage's stamp in WS/pano4d/stamps/<stage>.json.
class StageStamp {
 public:
  StageStamp(const Workspace& workspace, std::string stage);

  // Why the stage must run: no stamp (it never completed here), or what
  // differs from `inputs`; nullopt when it may be reused.
  std::optional<std::string> StaleReason(const StageInputs& inputs) const;
  // Before the stage starts: a run that fails leaves no stamp.
  void Remove() const;
  // Once the stage completed (atomically).
  void Write(const StageInputs& inputs) const;

 private:
  std::filesystem::path path_;
};

}  // namespace pano4d
