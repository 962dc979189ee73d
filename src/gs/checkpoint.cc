#include "src/gs/checkpoint.h"

#include <cerrno>
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

// Layout: 8-byte magic, uint64 header length, JSON header, the arrays the
// header lists (float32 little-endian, in order), then the Hash64 of every
// byte before it.
void WriteCheckpoint(const fs::path& path, const CheckpointState& state) {
  nlohmann::json header = {{"format", "pano4d checkpoint 2"},
                           {"iteration", state.iteration},
                           {"options", state.options},
                           {"fingerprint", state.fingerprint},
                           {"scene", state.scene},
                           {"views", state.views},
                           {"rng", state.rng},
                           {"order", state.order},
                           {"order_pos", state.order_pos},
                           {"reset_done", state.reset_done},
                           {"adam_steps", state.adam_steps},
                           {"sh_degree", state.sh_degree},
                           {"num_times", state.num_times},
                           {"canonical_time", state.canonical_time},
                           {"num_bases", state.num_bases},
                           {"counters", state.counters}};
  nlohmann::json list = nlohmann::json::array();
  for (const auto& [name, values] : state.arrays)
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
    for (const auto& [name, values] : state.arrays)
      write(values->data(), values->size() * sizeof(float));
    const std::uint64_t sum = checksum.value();
    out.write(reinterpret_cast<const char*>(&sum), sizeof(sum));
    out.flush();
    if (!out) throw WriteFailure(path, std::strerror(errno));
  });
}

namespace {

// Runs `read`, a malformed header (a missing key, a value of another type)
// reported as an Error naming `source`.
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

CheckpointReader::CheckpointReader(const fs::path& path)
    : CheckpointReader(ReadFileBytes(path), path.string()) {}

CheckpointReader::CheckpointReader(std::vector<std::uint8_t> data,
                                   std::string name)
    : source_(std::move(name)), bytes_(std::move(data)) {
  constexpr std::size_t kPrefix = sizeof(kCheckpointMagic) + 8;
  if (bytes_.size() < kPrefix) {
    throw Error(source_, "size", std::to_string(bytes_.size()),
                "too short for a pano4d checkpoint (truncated?)");
  }
  checked_ = !std::memcmp(bytes_.data(), kCheckpointMagic, 8);
  if (!checked_ && std::memcmp(bytes_.data(), kCheckpointMagicV1, 8))
    throw Error(source_, "magic", "", "not a pano4d checkpoint");
  if (checked_) {
    if (bytes_.size() < kPrefix + kChecksumSize) {
      throw Error(source_, "size", std::to_string(bytes_.size()),
                  "too short for a pano4d checkpoint (truncated?)");
    }
    std::uint64_t stored = 0;
    std::memcpy(&stored, bytes_.data() + bytes_.size() - kChecksumSize,
                kChecksumSize);
    bytes_.resize(bytes_.size() - kChecksumSize);
    Hash64 sum;
    sum.Add(bytes_.data(), bytes_.size());
    if (sum.value() != stored) {
      throw Error(source_, "checksum", "",
                  "the file does not match its checksum (corrupted on "
                  "disk, or copied or written only in part); fit without "
                  "--resume to start over");
    }
  }
  std::uint64_t length = 0;
  std::memcpy(&length, bytes_.data() + sizeof(kCheckpointMagic), 8);
  if (length > bytes_.size() - kPrefix) {
    throw Error(source_, "header length", std::to_string(length),
                "larger than the file (truncated?)");
  }
  header_ = ParseJson(
      std::string_view(reinterpret_cast<const char*>(bytes_.data() + kPrefix),
                       length),
      source_);
  WithHeaderErrors(source_, [&] {
    std::size_t offset = kPrefix + length;
    for (const Json& a : header_.at("arrays")) {
      const std::size_t count = a.at("count").get<std::size_t>();
      const std::string name = a.at("name").get<std::string>();
      if (count > (bytes_.size() - offset) / sizeof(float)) {
        throw Error(source_, "array " + name, std::to_string(count),
                    "extends past the end (truncated?)");
      }
      arrays_[name] = {offset, count};
      offset += count * sizeof(float);
    }
    if (offset != bytes_.size()) {
      throw Error(source_, "size", std::to_string(bytes_.size()),
                  "trailing bytes after the arrays (corrupt?)");
    }
    return 0;
  });
}

CheckpointState CheckpointReader::State() const {
  return WithHeaderErrors(source_, [&] {
    const Json& h = header_;
    CheckpointState s;
    s.iteration = h.at("iteration").get<std::int64_t>();
    s.options = h.value("options", Json());
    s.fingerprint = h.value("fingerprint", Json());
    s.scene = h.value("scene", std::string());
    s.views = h.at("views").get<std::vector<std::string>>();
    s.rng = h.at("rng").get<std::string>();
    s.order = h.at("order").get<std::vector<int>>();
    s.order_pos = h.at("order_pos").get<std::size_t>();
    s.reset_done = h.at("reset_done").get<bool>();
    s.adam_steps =
        h.at("adam_steps").get<std::map<std::string, std::int64_t>>();
    s.sh_degree = h.at("sh_degree").get<int>();
    s.num_times = h.at("num_times").get<int>();
    s.canonical_time = h.at("canonical_time").get<int>();
    s.num_bases = h.at("num_bases").get<int>();
    s.counters = h.value("counters", std::vector<std::int64_t>());
    return s;
  });
}

void CheckpointReader::Read(const std::string& name,
                            std::vector<float>* dst) const {
  const auto it = arrays_.find(name);
  if (it == arrays_.end()) throw Error(source_, "array", name, "missing");
  dst->resize(it->second.second);
  std::memcpy(dst->data(), bytes_.data() + it->second.first,
              it->second.second * sizeof(float));
  for (float v : *dst) {
    if (!std::isfinite(v)) {
      throw Error(source_, "array " + name, std::to_string(v),
                  "holds a non-finite value");
    }
  }
}

GaussianScene CheckpointReader::Scene() const {
  GaussianScene scene;
  WithHeaderErrors(source_, [&] {
    const int sh = header_.at("sh_degree").get<int>();
    scene.statics.sh_degree = scene.dynamics.sh_degree = sh;
    scene.num_times = header_.at("num_times").get<int>();
    scene.canonical_time = header_.at("canonical_time").get<int>();
    const int k = header_.at("num_bases").get<int>();
    scene.bases.num_bases = k;
    scene.bases.num_times = k > 0 ? scene.num_times : 0;
    return 0;
  });
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
    throw Error::In(source_, e.what());
  }
  return scene;
}

Json ReadCheckpointFingerprint(std::vector<std::uint8_t> bytes,
                               const std::string& source) {
  const CheckpointReader reader(std::move(bytes), source);
  return WithHeaderErrors(
      source, [&] { return reader.header().value("fingerprint", Json()); });
}

Json ReadCheckpointFingerprint(const fs::path& path) {
  return ReadCheckpointFingerprint(ReadFileBytes(path), path.string());
}

CheckpointFingerprints ReadCheckpointFingerprints(const fs::path& path) {
  const CheckpointReader reader(path);
  return WithHeaderErrors(reader.source(), [&] {
    return CheckpointFingerprints{
        reader.header().value("fingerprint", Json()),
        reader.header().value("scene", std::string())};
  });
}

GaussianScene ReadCheckpointScene(std::vector<std::uint8_t> bytes,
                                  const std::string& source) {
  return CheckpointReader(std::move(bytes), source).Scene();
}

GaussianScene ReadCheckpointScene(const fs::path& path) {
  return CheckpointReader(path).Scene();
}

}  // namespace pano4d
