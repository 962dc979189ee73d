#pragma once

// The compact 4D scene: what `pano4d view` loads in a browser and `pano4d
// export` writes beside the PLY sequence. The motion is stored as what it
// is (GaussianScene): static Gaussians once, canonical dynamic Gaussians
// once with their basis logits, and the K motion bases per time, so that
// T times cost K x T x 7 floats instead of T copies of every Gaussian.
//
// Two files: scene4d.json (the header below) and scene4d.bin (the arrays,
// little-endian, each at an offset that is a multiple of 4 bytes, so that
// a browser views them as typed arrays without copying).
//   {"format": "pano4d-scene4d", "version": 1, "binary": "scene4d.bin",
//    "binary_bytes": B, "num_times": T, "canonical_time": c, "sh_degree": d,
//    "statics":  {"count": N, "arrays": {NAME: {"offset", "dtype",
//                 "shape"}}},
//    "dynamics": {"count": M, "arrays": {...}},
//    "bases":    {"count": K, "arrays": {"rotations", "translations"}},
//    "extras":   {...}}
// Per Gaussian set: means float32 [n, 3]; log_scales, quats (w x y z,
// normalised), opacities (logits) and sh ([n, (d + 1)^2, 3],
// coefficient-major as GaussianModel) float16; dynamics also logits
// float16 [M, K]. Bases: rotations float32 [K, T, 4] (w x y z) and
// translations float32 [K, T, 3]. float16 changes a render by far less
// than 8-bit quantisation does (Scene4dTest asserts above 45 dB PSNR).

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "src/core/json.h"
#include "src/gs/scene.h"

namespace pano4d {

inline constexpr const char* kScene4dFormat = "pano4d-scene4d";
inline constexpr int kScene4dVersion = 1;
inline constexpr const char* kScene4dJson = "scene4d.json";
inline constexpr const char* kScene4dBinary = "scene4d.bin";

struct EncodedScene4d {
  Json header;
  std::string binary;
};

// `extras` (cameras, the panorama centre: whatever the reader shows beside
// the scene) goes under "extras" unchanged. Throws pano4d::Error for a
// scene whose arrays disagree (GaussianScene::Check) or hold a NaN or an
// infinity, or a value beyond float16's range in a float16 array.
EncodedScene4d EncodeScene4d(const GaussianScene& scene,
                             const Json& extras = Json::object());
// The scene back (float16 arrays widened to float); `extras` receives
// "extras". Throws pano4d::Error naming `source` for another format or
// version, an array outside the binary or of the wrong shape or type, or
// counts that disagree.
GaussianScene DecodeScene4d(const Json& header, std::string_view binary,
                            const std::string& source, Json* extras = nullptr);

// DIR/scene4d.json and DIR/scene4d.bin, each written atomically (the
// binary first, so that a header never names a missing binary); returns
// the bytes written.
std::uint64_t WriteScene4d(const std::filesystem::path& dir,
                           const GaussianScene& scene,
                           const Json& extras = Json::object());
GaussianScene ReadScene4d(const std::filesystem::path& dir,
                          Json* extras = nullptr);

}  // namespace pano4d
