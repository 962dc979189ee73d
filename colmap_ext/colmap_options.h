#pragma once

// COLMAP's command-line options across versions. pano4d writes its
// settings in COLMAP 3.8's option names (Debian 12's colmap); later
// versions renamed some (3.13: SiftExtraction.use_gpu ->
// FeatureExtraction.use_gpu, SiftMatching.use_gpu ->
// FeatureMatching.use_gpu). ColmapRunner reads the installed version from
// `colmap help` and each command's options from `colmap <command> -h`
// once, and maps every option onto the name that version accepts.
// Supported and tested: 3.8, 3.9, 3.11, 3.12, 3.13, 4.0, 4.1
// (tests/data/colmap_help/ holds their help outputs).

#include <optional>
#include <set>
#include <string>
#include <string_view>

namespace pano4d {

struct ColmapVersion {
  int major = 0, minor = 0, patch = 0;
  std::string text;  // as COLMAP prints it, e.g. "3.8", "4.1.1"
  bool operator<(const ColmapVersion& o) const {
    return major != o.major   ? major < o.major
           : minor != o.minor ? minor < o.minor
                              : patch < o.patch;
  }
};

// The oldest version pano4d runs (its database and model layouts are
// 3.8's), and the newest one tested; a newer one runs with a warning, as
// long as it accepts every option pano4d passes.
inline const ColmapVersion kOldestColmap{3, 8, 0, "3.8"};
inline const ColmapVersion kNewestTestedColmap{4, 1, 99, "4.1"};
inline constexpr const char* kTestedColmapVersions =
    "3.8, 3.9, 3.11, 3.12, 3.13, 4.0, 4.1";

// The version in the first line of `colmap help` (or of a command's -h,
// glog prefix allowed) that reads "COLMAP <digits>...", or nullopt.
std::optional<ColmapVersion> ParseColmapVersion(std::string_view help);

// The option names (without the leading "--") a `colmap <command> -h`
// lists, one per line as boost::program_options prints them.
std::set<std::string> ParseColmapOptions(std::string_view help);

// The name that a command accepting `accepted` takes for pano4d's option
// `option` (a 3.8 name, without "--"): the 3.8 name itself, or the first
// later name of it that the command lists. Throws pano4d::Error naming
// the version, the command and the option when the command lists none.
std::string MapColmapOption(const std::string& option,
                            const std::string& command,
                            const std::set<std::string>& accepted,
                            const ColmapVersion& version);

// Throws pano4d::Error naming the version and the supported range for a
// version older than kOldestColmap; returns false (the caller warns) for
// one newer than kNewestTestedColmap, true otherwise.
bool CheckColmapVersion(const ColmapVersion& version);

}  // namespace pano4d
