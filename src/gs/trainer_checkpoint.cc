// The trainer's state into and out of a checkpoint (src/gs/checkpoint.h):
// SaveCheckpoint fills a CheckpointState that points at the trainer's own
// arrays; a resume checks the file against this run and restores from it.
#include <cmath>
#include <sstream>
#include <utility>

#include "src/core/error.h"
#include "src/core/json.h"
#include "src/gs/checkpoint.h"
#include "src/gs/trainer.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// The optimisers by the name the checkpoint gives their arrays and steps.
template <typename TrainerAdams>
std::vector<std::pair<const char*, TrainerAdams*>> Optimisers(
    TrainerAdams* statics, TrainerAdams* dynamics, TrainerAdams* basis,
    TrainerAdams* appearance) {
  return {{"static", statics},
          {"dynamic", dynamics},
          {"basis", basis},
          {"appearance", appearance}};
}

std::string MomentName(const char* optimiser, const Adam& adam, int group,
                       const char* moment) {
  return std::string("adam.") + optimiser + "." + adam.name(group) + "." +
         moment;
}

}  // namespace

void Trainer::SetFingerprint(nlohmann::json fingerprint) {
  fingerprint_ = std::move(fingerprint);
}

void Trainer::SaveCheckpoint(const fs::path& path) const {
  CheckpointState state;
  std::vector<std::pair<std::string, const std::vector<float>*>>& arrays =
      state.arrays;
  const auto add_model = [&](const std::string& prefix,
                             const GaussianModel& m) {
    arrays.push_back({prefix + "means", &m.means});
    arrays.push_back({prefix + "log_scales", &m.log_scales});
    arrays.push_back({prefix + "quats", &m.quats});
    arrays.push_back({prefix + "opacities", &m.opacities});
    arrays.push_back({prefix + "sh", &m.sh});
  };
  add_model("static.", scene_.statics);
  add_model("dynamic.", scene_.dynamics);
  arrays.push_back({"logits", &scene_.logits});
  arrays.push_back({"bases.rotations", &scene_.bases.rotations});
  arrays.push_back({"bases.translations", &scene_.bases.translations});
  arrays.push_back({"appearance", &appearance_});
  for (auto [name, adam] : Optimisers(&static_adam_, &dynamic_adam_,
                                      &basis_adam_, &appearance_adam_)) {
    state.adam_steps[name] = adam->step();
    for (int g = 0; g < adam->groups(); ++g) {
      arrays.push_back(
          {MomentName(name, *adam, g, "m"), &adam->first_moment(g)});
      arrays.push_back(
          {MomentName(name, *adam, g, "v"), &adam->second_moment(g)});
    }
  }
  const DensifyStatistics& densify = strategy_.statistics();
  const std::vector<float> counts(densify.count.begin(), densify.count.end());
  arrays.push_back({"densify.gradient", &densify.gradient});
  arrays.push_back({"densify.count", &counts});
  arrays.push_back({"densify.radius", &densify.max_radius});

  std::ostringstream rng_state;
  rng_state << rng_;
  state.iteration = iteration_;
  state.options = options_.ToJson();
  state.fingerprint = fingerprint_;
  state.scene = scene_fingerprint_;
  for (const TrainingView& v : views_) state.views.push_back(v.name);
  state.rng = rng_state.str();
  state.order = order_;
  state.order_pos = order_pos_;
  state.reset_done = densify.reset_done;
  state.sh_degree = scene_.statics.sh_degree;
  state.num_times = scene_.num_times;
  state.canonical_time = scene_.canonical_time;
  state.num_bases = scene_.bases.num_bases;
  state.counters = {skipped_rows_total_, skipped_steps_total_,
                    strategy_.densified_total(), strategy_.pruned_total()};
  WriteCheckpoint(path, state);
}

void Trainer::LoadCheckpoint(const fs::path& path) {
  Restore(CheckpointReader(path));
}

void Trainer::LoadCheckpoint(std::vector<std::uint8_t> bytes,
                             const std::string& source) {
  Restore(CheckpointReader(std::move(bytes), source));
}

// Whether the checkpoint belongs to this run: its frames, its fingerprint,
// its format, its scene's shape, and counts within this run's.
void Trainer::CheckResumable(const CheckpointReader& file,
                             const CheckpointState& state) const {
  const std::string& source = file.source();
  std::vector<std::string> names;
  for (const TrainingView& v : views_) names.push_back(v.name);
  if (state.views != names) {
    throw Error(source, "views", "",
                "the checkpoint belongs to other frames "
                "(delete it or use another workspace)");
  }
  if (state.fingerprint.is_null()) {
    throw Error(source, "fingerprint", "",
                "missing: the checkpoint is from a pano4d that did not record "
                "its options; fit without --resume to start over");
  }
  if (const std::optional<JsonDifference> d =
          FirstDifference(state.fingerprint, fingerprint_)) {
    throw Error(source, d->path.empty() ? "options" : "option " + d->path,
                JsonValueForMessage(d->first),
                "this run has " + JsonValueForMessage(d->second) +
                    ": resume with the options the checkpoint was written "
                    "with, or fit without --resume to start over");
  }
  if (!file.has_checksum()) {
    throw Error(source, "format", "version 1",
                "written by an older pano4d, without a checksum or the "
                "scene it belongs to: it renders but does not resume; fit "
                "without --resume, or with --force, to start over");
  }
  if (state.scene != scene_fingerprint_) {
    throw Error(source, "scene", state.scene,
                "this workspace's frames hash to " + scene_fingerprint_ +
                    ": the checkpoint was written for other images, "
                    "cameras, times or depth (copied from another "
                    "workspace, or the frames changed since); fit without "
                    "--resume, or with --force, to start over");
  }
  if (state.iteration < 0 || state.iteration > options_.iterations) {
    throw Error(source, "iteration", std::to_string(state.iteration),
                "outside this run's 0.." + std::to_string(options_.iterations) +
                    " (corrupt checkpoint)");
  }
  for (const auto& [name, step] : state.adam_steps) {
    if (step < 0 || step > state.iteration)
      throw Error(source, "adam_steps." + name, std::to_string(step),
                  "outside 0.." + std::to_string(state.iteration) +
                      " (corrupt checkpoint)");
  }
  if (state.num_bases != scene_.bases.num_bases ||
      state.sh_degree != scene_.statics.sh_degree ||
      state.num_times != scene_.num_times) {
    throw Error(source, "scene", "",
                "motion bases, SH degree or times differ "
                "from this workspace's scene");
  }
}

// The scene's arrays (densification changed the row counts), then the
// optimisers' moments, which follow them, and the densification
// statistics.
void Trainer::RestoreArrays(const CheckpointReader& file,
                            const CheckpointState& state) {
  const std::string& source = file.source();
  {
    GaussianScene loaded = file.Scene();
    scene_.statics = std::move(loaded.statics);
    scene_.dynamics = std::move(loaded.dynamics);
    scene_.logits = std::move(loaded.logits);
    scene_.bases = std::move(loaded.bases);
    scene_.canonical_time = loaded.canonical_time;
  }
  file.Read("appearance", &appearance_);
  if (appearance_.size() != views_.size() * kAppearanceWidth) {
    throw Error(source, "appearance", std::to_string(appearance_.size()),
                "expected " + std::to_string(kAppearanceWidth) +
                    " values per training view");
  }
  for (auto [name, adam] : Optimisers(&static_adam_, &dynamic_adam_,
                                      &basis_adam_, &appearance_adam_)) {
    for (int g = 0; g < adam->groups(); ++g) {
      file.Read(MomentName(name, *adam, g, "m"), &adam->first_moment(g));
      file.Read(MomentName(name, *adam, g, "v"), &adam->second_moment(g));
    }
    const auto step = state.adam_steps.find(name);
    if (step == state.adam_steps.end())
      throw Error(source, "adam_steps", name, "missing");
    adam->set_step(step->second);
    if (const std::string problem = adam->RestoreRows(); !problem.empty()) {
      throw Error(source, std::string("adam.") + name, "",
                  problem + " (corrupt checkpoint)");
    }
  }
  DensifyStatistics& densify = strategy_.statistics();
  std::vector<float> counts;
  file.Read("densify.gradient", &densify.gradient);
  file.Read("densify.count", &counts);
  file.Read("densify.radius", &densify.max_radius);
  // Visits counted since the last densification: whole, at most one a step.
  for (float c : counts) {
    if (!(c >= 0 && c <= static_cast<float>(state.iteration) &&
          c == std::floor(c)))
      throw Error(source, "densify.count", std::to_string(c),
                  "not a count of steps in 0.." +
                      std::to_string(state.iteration) +
                      " (corrupt checkpoint)");
  }
  densify.count.assign(counts.begin(), counts.end());
  if (densify.gradient.size() != scene_.size() ||
      counts.size() != scene_.size() ||
      densify.max_radius.size() != scene_.size()) {
    throw Error(source, "densify", "", "statistics do not match the model");
  }
}

void Trainer::Restore(const CheckpointReader& file) {
  const CheckpointState state = file.State();
  const std::string& source = file.source();
  CheckResumable(file, state);
  RestoreArrays(file, state);
  std::istringstream rng_state(state.rng);
  rng_state >> rng_;
  order_ = state.order;
  order_pos_ = state.order_pos;
  for (int v : order_) {
    if (v < 0 || v >= static_cast<int>(views_.size())) {
      throw Error(source, "order", std::to_string(v),
                  "names a view that does not exist (corrupt checkpoint)");
    }
  }
  if (order_pos_ > order_.size()) {
    throw Error(source, "order_pos", std::to_string(order_pos_),
                "past the end of the epoch order (corrupt checkpoint)");
  }
  strategy_.statistics().reset_done = state.reset_done;
  iteration_ = state.iteration;
  if (state.counters.size() == 4) {
    skipped_rows_total_ = state.counters[0];
    skipped_steps_total_ = state.counters[1];
    strategy_.set_totals(state.counters[2], state.counters[3]);
  }
  UpdateLearningRates();
}

}  // namespace pano4d
