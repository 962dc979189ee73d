// Trainer checkpoints: everything a resumed run needs, in one file written
// atomically (src/gs/trainer.h).
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/hash.h"
#include "src/core/json.h"
#include "src/gs/trainer.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// Version 2 ends in a checksum; version 1 (no checksum, no scene
// fingerprint) is still read for its scene, never resumed.
constexpr char kCheckpointMagic[8] = {'P', '4', 'D', 'C', 'K', 'P', 'T', '2'};
constexpr char kCheckpointMagicV1[8] = {'P', '4', 'D', 'C', 'K', 'P', 'T', '1'};
constexpr std::size_t kChecksumSize = sizeof(std::uint64_t);

}  // namespace

std::string ViewsFingerprint(const std::vector<TrainingView>& views) {
  Hash64 hash;
  for (const TrainingView& v : views) {
    hash.AddString(v.name);
    hash.AddValue(v.time);
    const RasterCamera& c = v.camera;
    for (float x : {static_cast<float>(c.width), static_cast<float>(c.height),
                    c.fx, c.fy, c.cx, c.cy})
      hash.AddValue(x);
    hash.Add(c.rotation.data(), 9 * sizeof(float));
    hash.Add(c.translation.data(), 3 * sizeof(float));
    hash.AddArray(v.rgb);
    hash.AddArray(v.depth);
    hash.AddArray(v.dynamic);
    // Priors only when present: a fit without them keeps its fingerprint.
    if (!v.disparity.empty()) hash.AddArray(v.disparity);
    for (const TrainingView::Flow& f : v.flows) {
      hash.AddValue(f.view);
      hash.AddArray(f.flow);
      hash.AddArray(f.valid);
    }
  }
  return hash.Hex();
}

// Checkpoint layout: 8-byte magic, uint64 header length, JSON header, the
// arrays the header lists (float32 little-endian, in order), then the
// Hash64 of every byte before it.
void Trainer::SaveCheckpoint(const fs::path& path) const {
  std::vector<std::pair<std::string, const std::vector<float>*>> arrays;
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
  nlohmann::json adams = nlohmann::json::object();
  for (auto [name, adam] : {std::pair{"static", &static_adam_},
                            {"dynamic", &dynamic_adam_},
                            {"basis", &basis_adam_},
                            {"appearance", &appearance_adam_}}) {
    adams[name] = adam->step();
    for (int g = 0; g < adam->groups(); ++g) {
      arrays.push_back(
          {std::string("adam.") + name + "." + adam->name(g) + ".m",
           &adam->first_moment(g)});
      arrays.push_back(
          {std::string("adam.") + name + "." + adam->name(g) + ".v",
           &adam->second_moment(g)});
    }
  }
  const DensifyStatistics& densify = strategy_.statistics();
  std::vector<float> counts(densify.count.begin(), densify.count.end());
  arrays.push_back({"densify.gradient", &densify.gradient});
  arrays.push_back({"densify.count", &counts});
  arrays.push_back({"densify.radius", &densify.max_radius});

  std::ostringstream rng_state;
  rng_state << rng_;
  std::vector<std::string> names;
  for (const TrainingView& v : views_) names.push_back(v.name);
  nlohmann::json header = {
      {"format", "pano4d checkpoint 2"},
      {"iteration", iteration_},
      {"options", options_.ToJson()},
      {"fingerprint", fingerprint_},
      {"scene", scene_fingerprint_},
      {"views", names},
      {"rng", rng_state.str()},
      {"order", order_},
      {"order_pos", order_pos_},
      {"reset_done", densify.reset_done},
      {"adam_steps", adams},
      {"sh_degree", scene_.statics.sh_degree},
      {"num_times", scene_.num_times},
      {"canonical_time", scene_.canonical_time},
      {"num_bases", scene_.bases.num_bases},
      {"counters",
       {skipped_rows_total_, skipped_steps_total_, strategy_.densified_total(),
        strategy_.pruned_total()}}};
  nlohmann::json list = nlohmann::json::array();
  for (const auto& [name, values] : arrays)
    list.push_back({{"name", name}, {"count", values->size()}});
  header["arrays"] = list;
  const std::string text = header.dump();
  WriteAtomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    Hash64 checksum;
    const auto write = [&](const void* data, std::size_t size) {
      checksum.Add(data, size);
      out.write(static_cast<const char*>(data),
                static_cast<std::streamsize>(size));
    };
    write(kCheckpointMagic, sizeof(kCheckpointMagic));
    const std::uint64_t length = text.size();
    write(&length, sizeof(length));
    write(text.data(), text.size());
    for (const auto& [name, values] : arrays)
      write(values->data(), values->size() * sizeof(float));
    const std::uint64_t sum = checksum.value();
    out.write(reinterpret_cast<const char*>(&sum), sizeof(sum));
    out.flush();
    if (!out) throw WriteFailure(path, std::strerror(errno));
  });
}

// A checkpoint file read into memory and checked against its checksum: its
// JSON header and where each array lies.
struct CheckpointFile {
  std::string source;
  std::vector<std::uint8_t> bytes;
  Json header;
  std::map<std::string, std::pair<std::size_t, std::size_t>> arrays;

  bool checked = false;  // version 2: the checksum matched

  CheckpointFile(std::vector<std::uint8_t> data, std::string name)
      : source(std::move(name)), bytes(std::move(data)) {
    constexpr std::size_t kPrefix = sizeof(kCheckpointMagic) + 8;
    if (bytes.size() < kPrefix) {
      throw Error(source, "size", std::to_string(bytes.size()),
                  "too short for a pano4d checkpoint (truncated?)");
    }
    checked = !std::memcmp(bytes.data(), kCheckpointMagic, 8);
    if (!checked && std::memcmp(bytes.data(), kCheckpointMagicV1, 8))
      throw Error(source, "magic", "", "not a pano4d checkpoint");
    if (checked) {
      if (bytes.size() < kPrefix + kChecksumSize) {
        throw Error(source, "size", std::to_string(bytes.size()),
                    "too short for a pano4d checkpoint (truncated?)");
      }
      std::uint64_t stored = 0;
      std::memcpy(&stored, bytes.data() + bytes.size() - kChecksumSize,
                  kChecksumSize);
      bytes.resize(bytes.size() - kChecksumSize);
      Hash64 sum;
      sum.Add(bytes.data(), bytes.size());
      if (sum.value() != stored) {
        throw Error(source, "checksum", "",
                    "the file does not match its checksum (corrupted on "
                    "disk, or copied or written only in part); fit without "
                    "--resume to start over");
      }
    }
    std::uint64_t length = 0;
    std::memcpy(&length, bytes.data() + sizeof(kCheckpointMagic), 8);
    if (length > bytes.size() - kPrefix) {
      throw Error(source, "header length", std::to_string(length),
                  "larger than the file (truncated?)");
    }
    header = ParseJson(
        std::string_view(reinterpret_cast<const char*>(bytes.data() + kPrefix),
                         length),
        source);
    std::size_t offset = kPrefix + length;
    for (const Json& a : header.at("arrays")) {
      const std::size_t count = a.at("count").get<std::size_t>();
      const std::string name = a.at("name").get<std::string>();
      if (count > (bytes.size() - offset) / sizeof(float)) {
        throw Error(source, "array " + name, std::to_string(count),
                    "extends past the end (truncated?)");
      }
      arrays[name] = {offset, count};
      offset += count * sizeof(float);
    }
    if (offset != bytes.size()) {
      throw Error(source, "size", std::to_string(bytes.size()),
                  "trailing bytes after the arrays (corrupt?)");
    }
  }

  void Read(const std::string& name, std::vector<float>* dst) const {
    const auto it = arrays.find(name);
    if (it == arrays.end()) throw Error(source, "array", name, "missing");
    dst->resize(it->second.second);
    std::memcpy(dst->data(), bytes.data() + it->second.first,
                it->second.second * sizeof(float));
    for (float v : *dst) {
      if (!std::isfinite(v)) {
        throw Error(source, "array " + name, std::to_string(v),
                    "holds a non-finite value");
      }
    }
  }

  GaussianScene Scene() const {
    GaussianScene scene;
    const int sh = header.at("sh_degree").get<int>();
    scene.statics.sh_degree = scene.dynamics.sh_degree = sh;
    scene.num_times = header.at("num_times").get<int>();
    scene.canonical_time = header.at("canonical_time").get<int>();
    const int k = header.at("num_bases").get<int>();
    scene.bases.num_bases = k;
    scene.bases.num_times = k > 0 ? scene.num_times : 0;
    const auto read_model = [&](const std::string& prefix, GaussianModel* m) {
      Read(prefix + "means", &m->means);
      Read(prefix + "log_scales", &m->log_scales);
      Read(prefix + "quats", &m->quats);
      Read(prefix + "opacities", &m->opacities);
      Read(prefix + "sh", &m->sh);
    };
    read_model("static.", &scene.statics);
    read_model("dynamic.", &scene.dynamics);
    Read("logits", &scene.logits);
    Read("bases.rotations", &scene.bases.rotations);
    Read("bases.translations", &scene.bases.translations);
    try {
      scene.Check();
    } catch (const Error& e) {  // the file's content: name the file
      throw Error::In(source, e.what());
    }
    return scene;
  }
};

namespace {

// Runs `read` on the checkpoint, a malformed header (a missing key, a value
// of another type) reported as an Error naming `source`.
template <typename Read>
auto WithHeaderErrors(const std::string& source, Read read) {
  try {
    return read();
  } catch (const nlohmann::json::exception& e) {
    throw Error(source, "header", "",
                std::string("malformed checkpoint header: ") + e.what());
  }
}

}  // namespace

Json ReadCheckpointFingerprint(std::vector<std::uint8_t> bytes,
                               const std::string& source) {
  return WithHeaderErrors(source, [&] {
    const CheckpointFile file(std::move(bytes), source);
    return file.header.contains("fingerprint") ? file.header["fingerprint"]
                                               : Json();
  });
}

Json ReadCheckpointFingerprint(const fs::path& path) {
  return ReadCheckpointFingerprint(ReadFileBytes(path), path.string());
}

CheckpointFingerprints ReadCheckpointFingerprints(const fs::path& path) {
  return WithHeaderErrors(path.string(), [&] {
    const CheckpointFile file(ReadFileBytes(path), path.string());
    return CheckpointFingerprints{file.header.value("fingerprint", Json()),
                                  file.header.value("scene", std::string())};
  });
}

GaussianScene ReadCheckpointScene(std::vector<std::uint8_t> bytes,
                                  const std::string& source) {
  return WithHeaderErrors(
      source, [&] { return CheckpointFile(std::move(bytes), source).Scene(); });
}

GaussianScene ReadCheckpointScene(const fs::path& path) {
  return ReadCheckpointScene(ReadFileBytes(path), path.string());
}

void Trainer::SetFingerprint(nlohmann::json fingerprint) {
  fingerprint_ = std::move(fingerprint);
}

void Trainer::LoadCheckpoint(const fs::path& path) {
  LoadCheckpoint(ReadFileBytes(path), path.string());
}

void Trainer::LoadCheckpoint(std::vector<std::uint8_t> bytes,
                             const std::string& source) {
  WithHeaderErrors(source,
                   [&] { Restore(CheckpointFile(std::move(bytes), source)); });
}

void Trainer::Restore(const CheckpointFile& file) {
  const std::string& source = file.source;
  const Json& header = file.header;
  std::vector<std::string> names;
  for (const TrainingView& v : views_) names.push_back(v.name);
  if (header.at("views").get<std::vector<std::string>>() != names) {
    throw Error(source, "views", "",
                "the checkpoint belongs to other frames "
                "(delete it or use another workspace)");
  }
  if (!header.contains("fingerprint")) {
    throw Error(source, "fingerprint", "",
                "missing: the checkpoint is from a pano4d that did not record "
                "its options; fit without --resume to start over");
  }
  if (const std::optional<JsonDifference> d =
          FirstDifference(header["fingerprint"], fingerprint_)) {
    throw Error(source, d->path.empty() ? "options" : "option " + d->path,
                JsonValueForMessage(d->first),
                "this run has " + JsonValueForMessage(d->second) +
                    ": resume with the options the checkpoint was written "
                    "with, or fit without --resume to start over");
  }
  if (!file.checked) {
    throw Error(source, "format", "version 1",
                "written by an older pano4d, without a checksum or the "
                "scene it belongs to: it renders but does not resume; fit "
                "without --resume, or with --force, to start over");
  }
  const std::string scene = header.at("scene").get<std::string>();
  if (scene != scene_fingerprint_) {
    throw Error(source, "scene", scene,
                "this workspace's frames hash to " + scene_fingerprint_ +
                    ": the checkpoint was written for other images, "
                    "cameras, times or depth (copied from another "
                    "workspace, or the frames changed since); fit without "
                    "--resume, or with --force, to start over");
  }
  const std::int64_t iteration = header.at("iteration").get<std::int64_t>();
  if (iteration < 0 || iteration > options_.iterations) {
    throw Error(source, "iteration", std::to_string(iteration),
                "outside this run's 0.." + std::to_string(options_.iterations) +
                    " (corrupt checkpoint)");
  }
  for (const auto& [name, step] : header.at("adam_steps").items()) {
    if (step.get<std::int64_t>() < 0 || step.get<std::int64_t>() > iteration)
      throw Error(
          source, "adam_steps." + name, step.dump(),
          "outside 0.." + std::to_string(iteration) + " (corrupt checkpoint)");
  }
  if (header.at("num_bases").get<int>() != scene_.bases.num_bases ||
      header.at("sh_degree").get<int>() != scene_.statics.sh_degree ||
      header.at("num_times").get<int>() != scene_.num_times) {
    throw Error(source, "scene", "",
                "motion bases, SH degree or times differ "
                "from this workspace's scene");
  }

  // The scene's arrays (densification changed the row counts), then the
  // optimisers' moments, which follow them.
  {
    GaussianScene loaded = file.Scene();
    scene_.statics = std::move(loaded.statics);
    scene_.dynamics = std::move(loaded.dynamics);
    scene_.logits = std::move(loaded.logits);
    scene_.bases = std::move(loaded.bases);
    scene_.canonical_time = loaded.canonical_time;
  }
  const auto read = [&](const std::string& name, std::vector<float>* dst) {
    file.Read(name, dst);
  };
  read("appearance", &appearance_);
  if (appearance_.size() != views_.size() * kAppearanceWidth) {
    throw Error(source, "appearance", std::to_string(appearance_.size()),
                "expected " + std::to_string(kAppearanceWidth) +
                    " values per training view");
  }
  for (auto [name, adam] : {std::pair{"static", &static_adam_},
                            {"dynamic", &dynamic_adam_},
                            {"basis", &basis_adam_},
                            {"appearance", &appearance_adam_}}) {
    for (int g = 0; g < adam->groups(); ++g) {
      read(std::string("adam.") + name + "." + adam->name(g) + ".m",
           &adam->first_moment(g));
      read(std::string("adam.") + name + "." + adam->name(g) + ".v",
           &adam->second_moment(g));
    }
    adam->set_step(header.at("adam_steps").at(name).get<std::int64_t>());
    adam->RestoreRows();
  }
  DensifyStatistics& densify = strategy_.statistics();
  std::vector<float> counts;
  read("densify.gradient", &densify.gradient);
  read("densify.count", &counts);
  read("densify.radius", &densify.max_radius);
  // Visits counted since the last densification: whole, at most one a step.
  for (float c : counts) {
    if (!(c >= 0 && c <= static_cast<float>(iteration) && c == std::floor(c)))
      throw Error(source, "densify.count", std::to_string(c),
                  "not a count of steps in 0.." + std::to_string(iteration) +
                      " (corrupt checkpoint)");
  }
  densify.count.assign(counts.begin(), counts.end());
  if (densify.gradient.size() != scene_.size() ||
      counts.size() != scene_.size() ||
      densify.max_radius.size() != scene_.size()) {
    throw Error(source, "densify", "", "statistics do not match the model");
  }
  std::istringstream rng_state(header.at("rng").get<std::string>());
  rng_state >> rng_;
  order_ = header.at("order").get<std::vector<int>>();
  order_pos_ = header.at("order_pos").get<std::size_t>();
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
  densify.reset_done = header.at("reset_done").get<bool>();
  iteration_ = iteration;
  const std::vector<std::int64_t> counters =
      header.at("counters").get<std::vector<std::int64_t>>();
  if (counters.size() == 4) {
    skipped_rows_total_ = counters[0];
    skipped_steps_total_ = counters[1];
    strategy_.set_totals(counters[2], counters[3]);
  }
  UpdateLearningRates();
}

}  // namespace pano4d
