#pragma once

// A fit's checkpoint as plain state: CheckpointState holds what a resumed
// run needs (the scene, the optimisers' moments and steps, the random
// generator, the epoch order, the densification statistics, the
// fingerprints), WriteCheckpoint writes it and CheckpointReader reads it
// back. The trainer fills one and restores from one (trainer_checkpoint.cc);
// readers of a scene (render, export, view, expand, the benchmarks) need no
// trainer. The file's layout is in docs/formats.md.

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/gs/scene.h"
#include "src/gs/training_view.h"

namespace pano4d {

// The header's values and the arrays, by name in file order. To write, each
// array points at the vector it is written from (nothing is copied); a
// reader's State() leaves `arrays` empty and Read() fills the caller's.
struct CheckpointState {
  std::int64_t iteration = 0;
  nlohmann::json options;          // the trainer's (TrainerOptions::ToJson)
  nlohmann::json fingerprint;      // what a resuming run must share; null: none
  std::string scene;               // ViewsFingerprint; empty in format 1
  std::vector<std::string> views;  // the training views' names, in order
  std::string rng;                 // the std::mt19937_64's state as text
  std::vector<int> order;          // the epoch's view order
  std::size_t order_pos = 0;       // the next view's position in it
  bool reset_done = false;         // densification's last opacity reset
  std::map<std::string, std::int64_t> adam_steps;  // per optimiser
  int sh_degree = 0, num_times = 0, canonical_time = 0, num_bases = 0;
  // Skipped rows, skipped steps, Gaussians densified and pruned (empty in
  // files from before pano4d counted them).
  std::vector<std::int64_t> counters;
  std::vector<std::pair<std::string, const std::vector<float>*>> arrays;
};

// Writes `state` in format 2, atomically (a temporary renamed); throws
// WriteFailure naming the file.
void WriteCheckpoint(const std::filesystem::path& path,
                     const CheckpointState& state);

// A checkpoint read into memory and checked against its checksum. Every
// error is a pano4d::Error naming `source`: not a checkpoint, truncated, a
// checksum that does not match, a malformed header, a non-finite value.
class CheckpointReader {
 public:
  CheckpointReader(std::vector<std::uint8_t> bytes, std::string source);
  explicit CheckpointReader(const std::filesystem::path& path);

  const std::string& source() const { return source_; }
  // Format 2 (its checksum matched); format 1 renders, never resumes.
  bool has_checksum() const { return checked_; }
  // The header's values (`arrays` empty).
  CheckpointState State() const;
  // The header as written (docs/formats.md), for readers of one value.
  const nlohmann::json& header() const { return header_; }
  // Array `name` into `dst`.
  void Read(const std::string& name, std::vector<float>* dst) const;
  // The Gaussians, checked (GaussianScene::Check).
  GaussianScene Scene() const;

 private:
  std::string source_;
  std::vector<std::uint8_t> bytes_;
  nlohmann::json header_;
  std::map<std::string, std::pair<std::size_t, std::size_t>> arrays_;
  bool checked_ = false;
};

// The scene stored in a checkpoint (to construct the Trainer that
// LoadCheckpoint then restores), as CheckpointReader::Scene. The byte
// overloads read a checkpoint in memory (`source` names it in errors); the
// path overloads read the file.
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
