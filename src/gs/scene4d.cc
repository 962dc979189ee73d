#include "src/gs/scene4d.h"

#include <cmath>
#include <cstring>
#include <vector>

#include <Eigen/Core>

#include "src/core/error.h"
#include "src/core/file.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// The largest finite float16.
constexpr float kFloat16Max = 65504.0f;

enum class Dtype { kFloat32, kFloat16 };

const char* DtypeName(Dtype d) {
  return d == Dtype::kFloat32 ? "float32" : "float16";
}
std::size_t DtypeBytes(Dtype d) { return d == Dtype::kFloat32 ? 4 : 2; }

// Appends arrays to the binary and describes each in the header.
class Writer {
 public:
  Json Add(const std::vector<float>& values, Dtype dtype,
           std::vector<std::size_t> shape, const std::string& name) {
    std::size_t count = 1;
    for (const std::size_t s : shape) count *= s;
    if (count != values.size()) {
      throw Error("scene4d", name, std::to_string(values.size()) + " values",
                  "expected " + std::to_string(count));
    }
    const std::size_t offset = binary_.size();
    binary_.resize(offset + count * DtypeBytes(dtype));
    char* out = binary_.data() + offset;
    for (std::size_t i = 0; i < count; ++i) {
      const float v = values[i];
      if (!std::isfinite(v) ||
          (dtype == Dtype::kFloat16 && std::abs(v) > kFloat16Max)) {
        throw Error(
            "scene4d", name + "[" + std::to_string(i) + "]", std::to_string(v),
            dtype == Dtype::kFloat16 ? "is not a finite float16 (|v| <= 65504)"
                                     : "is not finite");
      }
      if (dtype == Dtype::kFloat32) {
        std::memcpy(out + i * 4, &v, 4);
      } else {
        const std::uint16_t bits =
            Eigen::numext::bit_cast<std::uint16_t>(Eigen::half(v));
        std::memcpy(out + i * 2, &bits, 2);
      }
    }
    // Typed-array views need offsets that are multiples of their size.
    binary_.resize((binary_.size() + 3) / 4 * 4, '\0');
    return {{"offset", offset}, {"dtype", DtypeName(dtype)}, {"shape", shape}};
  }
  std::string Take() { return std::move(binary_); }

 private:
  std::string binary_;
};

// Quaternions normalised, as the rasterizer uses them: float16 keeps
// unit-scale values best.
std::vector<float> Normalised(const std::vector<float>& quats) {
  std::vector<float> out(quats.size());
  for (std::size_t i = 0; i + 3 < quats.size(); i += 4) {
    const float n =
        std::sqrt(quats[i] * quats[i] + quats[i + 1] * quats[i + 1] +
                  quats[i + 2] * quats[i + 2] + quats[i + 3] * quats[i + 3]);
    for (int j = 0; j < 4; ++j) out[i + j] = n > 0 ? quats[i + j] / n : 0.f;
  }
  return out;
}

Json EncodeModel(const GaussianModel& m, Writer* w, const std::string& set) {
  const std::size_t n = m.size();
  const std::size_t k = m.sh_coefficients();
  Json arrays = {
      {"means", w->Add(m.means, Dtype::kFloat32, {n, 3}, set + ".means")},
      {"log_scales",
       w->Add(m.log_scales, Dtype::kFloat16, {n, 3}, set + ".log_scales")},
      {"quats",
       w->Add(Normalised(m.quats), Dtype::kFloat16, {n, 4}, set + ".quats")},
      {"opacities",
       w->Add(m.opacities, Dtype::kFloat16, {n}, set + ".opacities")},
      {"sh", w->Add(m.sh, Dtype::kFloat16, {n, k, 3}, set + ".sh")}};
  return {{"count", n}, {"arrays", arrays}};
}

// Reads arrays the header describes, checking each against the binary.
class Reader {
 public:
  Reader(std::string_view binary, std::string source)
      : binary_(binary), source_(std::move(source)) {}

  std::vector<float> Get(const Json& arrays, const std::string& set,
                         const std::string& name,
                         const std::vector<std::size_t>& shape) const {
    const std::string field = set + ".arrays." + name;
    const Json a = GetJson<Json>(arrays, name, source_ + " " + set);
    const std::string dtype = GetJson<std::string>(a, "dtype", field);
    const std::int64_t offset = GetJson<std::int64_t>(a, "offset", field);
    const std::vector<int> found = GetJson<std::vector<int>>(a, "shape", field);
    if (found != std::vector<int>(shape.begin(), shape.end())) {
      throw Error(source_, field + ".shape", JsonValueForMessage(a["shape"]),
                  "expected " + Json(shape).dump());
    }
    if (dtype != "float32" && dtype != "float16") {
      throw Error(source_, field + ".dtype", dtype,
                  "expected float32 or float16");
    }
    const Dtype d = dtype == "float32" ? Dtype::kFloat32 : Dtype::kFloat16;
    std::size_t count = 1;
    for (const std::size_t s : shape) count *= s;
    const std::size_t bytes = count * DtypeBytes(d);
    if (offset < 0 || static_cast<std::size_t>(offset) > binary_.size() ||
        bytes > binary_.size() - offset) {
      throw Error(source_, field + ".offset", std::to_string(offset),
                  std::to_string(bytes) + " bytes from there exceed the " +
                      std::to_string(binary_.size()) + "-byte binary");
    }
    std::vector<float> out(count);
    const char* in = binary_.data() + offset;
    for (std::size_t i = 0; i < count; ++i) {
      if (d == Dtype::kFloat32) {
        std::memcpy(&out[i], in + i * 4, 4);
      } else {
        std::uint16_t bits;
        std::memcpy(&bits, in + i * 2, 2);
        out[i] = static_cast<float>(Eigen::numext::bit_cast<Eigen::half>(bits));
      }
      if (!std::isfinite(out[i])) {
        throw Error(source_, field + "[" + std::to_string(i) + "]",
                    std::to_string(out[i]), "is not finite");
      }
    }
    return out;
  }

  GaussianModel Model(const Json& header, const std::string& set, int sh_degree,
                      std::size_t* count) const {
    const Json s = GetJson<Json>(header, set, source_);
    const std::int64_t n =
        GetJson<std::int64_t>(s, "count", source_ + " " + set);
    if (n < 0)
      throw Error(source_, set + ".count", std::to_string(n),
                  "must not be negative");
    *count = static_cast<std::size_t>(n);
    const Json arrays = GetJson<Json>(s, "arrays", source_ + " " + set);
    const std::size_t k = (sh_degree + 1) * (sh_degree + 1);
    GaussianModel m;
    m.sh_degree = sh_degree;
    m.means = Get(arrays, set, "means", {*count, 3});
    m.log_scales = Get(arrays, set, "log_scales", {*count, 3});
    m.quats = Get(arrays, set, "quats", {*count, 4});
    m.opacities = Get(arrays, set, "opacities", {*count});
    m.sh = Get(arrays, set, "sh", {*count, k, 3});
    return m;
  }

 private:
  std::string_view binary_;
  std::string source_;
};

}  // namespace

EncodedScene4d EncodeScene4d(const GaussianScene& scene, const Json& extras) {
  scene.Check();
  Writer w;
  Json header = {{"format", kScene4dFormat},
                 {"version", kScene4dVersion},
                 {"binary", kScene4dBinary},
                 {"num_times", scene.num_times},
                 {"canonical_time", scene.canonical_time},
                 {"sh_degree", scene.statics.sh_degree}};
  header["statics"] = EncodeModel(scene.statics, &w, "statics");
  header["dynamics"] = EncodeModel(scene.dynamics, &w, "dynamics");
  const std::size_t m = scene.dynamics.size();
  const std::size_t k = scene.bases.num_bases;
  const std::size_t t = scene.bases.num_times;
  header["dynamics"]["arrays"]["logits"] =
      w.Add(scene.logits, Dtype::kFloat16, {m, k}, "dynamics.logits");
  header["bases"] = {
      {"count", k},
      {"arrays",
       {{"rotations", w.Add(scene.bases.rotations, Dtype::kFloat32, {k, t, 4},
                            "bases.rotations")},
        {"translations", w.Add(scene.bases.translations, Dtype::kFloat32,
                               {k, t, 3}, "bases.translations")}}}};
  header["extras"] = extras;
  EncodedScene4d out;
  out.binary = w.Take();
  header["binary_bytes"] = out.binary.size();
  out.header = std::move(header);
  return out;
}

GaussianScene DecodeScene4d(const Json& header, std::string_view binary,
                            const std::string& source, Json* extras) {
  const std::string format = GetJson<std::string>(header, "format", source);
  if (format != kScene4dFormat) {
    throw Error(source, "format", format,
                std::string("expected ") + kScene4dFormat);
  }
  const int version = GetJson<int>(header, "version", source);
  if (version != kScene4dVersion) {
    throw Error(source, "version", std::to_string(version),
                "this pano4d reads version " + std::to_string(kScene4dVersion));
  }
  const std::int64_t bytes =
      GetJson<std::int64_t>(header, "binary_bytes", source);
  if (bytes != static_cast<std::int64_t>(binary.size())) {
    throw Error(source, "binary_bytes", std::to_string(bytes),
                "the binary holds " + std::to_string(binary.size()) +
                    " bytes (truncated or from another export)");
  }
  const int sh_degree = GetJson<int>(header, "sh_degree", source);
  if (sh_degree < 0 || sh_degree > 3) {
    throw Error(source, "sh_degree", std::to_string(sh_degree),
                "expected 0..3");
  }
  const Reader r(binary, source);
  GaussianScene scene;
  scene.num_times = GetJson<int>(header, "num_times", source);
  scene.canonical_time = GetJson<int>(header, "canonical_time", source);
  std::size_t n = 0, m = 0;
  scene.statics = r.Model(header, "statics", sh_degree, &n);
  scene.dynamics = r.Model(header, "dynamics", sh_degree, &m);
  const Json bases = GetJson<Json>(header, "bases", source);
  const int k = GetJson<int>(bases, "count", source + " bases");
  if (k < 0)
    throw Error(source, "bases.count", std::to_string(k),
                "must not be negative");
  const Json dynamic_arrays = GetJson<Json>(
      GetJson<Json>(header, "dynamics", source), "arrays", source);
  const Json basis_arrays = GetJson<Json>(bases, "arrays", source + " bases");
  const std::size_t t = k > 0 ? scene.num_times : 0;
  scene.logits = r.Get(dynamic_arrays, "dynamics", "logits",
                       {m, static_cast<std::size_t>(k)});
  if (k > 0) {
    scene.bases.num_bases = k;
    scene.bases.num_times = scene.num_times;
    scene.bases.rotations =
        r.Get(basis_arrays, "bases", "rotations", {std::size_t(k), t, 4});
    scene.bases.translations =
        r.Get(basis_arrays, "bases", "translations", {std::size_t(k), t, 3});
  }
  try {
    scene.Check();
  } catch (const Error& e) {
    throw Error::In(source, e.what());
  }
  if (extras != nullptr) *extras = header.value("extras", Json::object());
  return scene;
}

std::uint64_t WriteScene4d(const fs::path& dir, const GaussianScene& scene,
                           const Json& extras) {
  const EncodedScene4d encoded = EncodeScene4d(scene, extras);
  EnsureDirectory(dir);
  WriteFileAtomically(dir / kScene4dBinary, encoded.binary);
  const std::string header = encoded.header.dump() + "\n";
  WriteFileAtomically(dir / kScene4dJson, header);
  return encoded.binary.size() + header.size();
}

GaussianScene ReadScene4d(const fs::path& dir, Json* extras) {
  const fs::path header = dir / kScene4dJson;
  const std::vector<std::uint8_t> binary = ReadFileBytes(dir / kScene4dBinary);
  return DecodeScene4d(
      ReadJson(header),
      std::string_view(reinterpret_cast<const char*>(binary.data()),
                       binary.size()),
      header.string(), extras);
}

}  // namespace pano4d
