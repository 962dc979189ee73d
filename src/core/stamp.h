#pragma once

// Stage stamps: the one way pano4d decides whether a stage's earlier result
// can be reused (sfm's steps, depth, the fit). A stamp records what the stage
// ran with (options), what it read (files by size and modification time,
// inputs held in memory by fingerprint) and what it wrote (paths that must
// still exist). It is removed when the stage starts and written once it
// completed, so a later run reuses a stage only when nothing it read changed
// and what it wrote is still there, and says why it runs one again.

#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "src/core/workspace.h"

namespace pano4d {

// What a stage ran with, read and wrote, as its stamp records it.
class StageRecord {
 public:
  // Paths under `root` (the workspace) are recorded relative to it, so a
  // workspace copied with its modification times keeps its stamps.
  explicit StageRecord(std::filesystem::path root) : root_(std::move(root)) {}

  StageRecord& Option(const std::string& key, nlohmann::json value);
  // A file's size and modification time; a folder's: every regular file
  // under it (following links to folders; the workspace and its pano4d/
  // are left out); a path that does not exist is recorded as missing.
  StageRecord& File(const std::filesystem::path& path);
  // An input the stage holds in memory, by a fingerprint of its contents
  // (e.g. the fit's training frames); said by `name` when it differs.
  StageRecord& Content(const std::string& name, const std::string& fingerprint);
  // A file or folder the stage wrote, which later stages may change: only
  // that it still exists is checked.
  StageRecord& Output(const std::filesystem::path& path);

  const nlohmann::json& json() const { return json_; }

 private:
  std::string Key(const std::filesystem::path& path) const;

  std::filesystem::path root_;
  nlohmann::json json_ = {{"options", nlohmann::json::object()},
                          {"files", nlohmann::json::object()},
                          {"contents", nlohmann::json::object()},
                          {"outputs", nlohmann::json::array()}};
};

// Why a stage that completed with the `stamped` record must run again for
// `now`: the first option, file or content that differs, said for a person
// ("option factor was 2, now 1", "images/0003.png changed", "depth/x.npy is
// new", "the training frames changed"); nullopt when they are the same.
// Outputs are not compared here (StageStamp checks that they exist).
std::optional<std::string> RecordDifference(const nlohmann::json& stamped,
                                            const nlohmann::json& now);

// One stage's stamp in WS/pano4d/stamps/<stage>.json (a stage named
// "sfm/mapper" in stamps/sfm/mapper.json).
class StageStamp {
 public:
  StageStamp(const Workspace& workspace, std::string stage);

  // Why the stage must run: no stamp (it never completed here), what
  // differs from `now`, or an output that is gone; nullopt when it may be
  // reused.
  std::optional<std::string> StaleReason(const StageRecord& now) const;
  // Decides and says so in the log, the same words for every stage
  // ("<stage> runs: <why>", "<stage> reused: nothing it read changed"):
  // `forced` (e.g. "--force", "an earlier step ran") runs it whatever the
  // stamp says. Returns why it runs, nullopt when it is reused.
  std::optional<std::string> Decide(
      const StageRecord& now,
      const std::optional<std::string>& forced = std::nullopt) const;
  // The seconds the stage took when its stamp was written (0 when the stamp
  // records none).
  double Seconds() const;
  // Before the stage starts: a run that fails leaves no stamp.
  void Remove() const;
  // Once the stage completed (atomically).
  void Write(const StageRecord& record, double seconds = 0) const;

  const std::string& stage() const { return stage_; }

 private:
  std::string stage_;
  std::filesystem::path root_;
  std::filesystem::path path_;
};

}  // namespace pano4d
