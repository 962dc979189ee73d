#pragma once

// Reading a fit's checkpoint without a trainer: the scene it holds (for
// render, export, view, expand and the benchmarks) and the fingerprints a
// resuming run compares. The trainer writes and restores the whole state
// (Trainer::SaveCheckpoint, LoadCheckpoint); the file's layout is in
// docs/formats.md.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/gs/scene.h"
#include "src/gs/training_view.h"

namespace pano4d {

// The scene stored in a checkpoint (to construct the Trainer that
// LoadCheckpoint then restores). Throws pano4d::Error naming the file when
// it is not a pano4d checkpoint, is truncated or holds non-finite values.
// The byte overloads read a checkpoint in memory (`source` names it in
// errors); the path overloads read the file.
GaussianScene ReadCheckpointScene(const std::filesystem::path& path);
GaussianScene ReadCheckpointScene(std::vector<std::uint8_t> bytes,
                                  const std::string& source);
// The fingerprint a checkpoint was written with (Trainer::SetFingerprint);
// null for a checkpoint from before pano4d stored one.
nlohmann::json ReadCheckpointFingerprint(const std::filesystem::path& path);
nlohmann::json ReadCheckpointFingerprint(std::vector<std::uint8_t> bytes,
                                         const std::string& source);
// Both fingerprints from one read of the file: the options' (as above) and
// the scene's (ViewsFingerprint; empty before pano4d stored one).
struct CheckpointFingerprints {
  nlohmann::json options;
  std::string scene;
};
CheckpointFingerprints ReadCheckpointFingerprints(
    const std::filesystem::path& path);

// The scene the views show, as a checkpoint records it: a hash of their
// names, times, cameras, images, depth and dynamic masks.
std::string ViewsFingerprint(const std::vector<TrainingView>& views);

}  // namespace pano4d
