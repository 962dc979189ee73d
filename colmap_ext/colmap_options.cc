#include "colmap_ext/colmap_options.h"

#include <map>
#include <regex>
#include <sstream>
#include <vector>

#include "src/core/error.h"

namespace pano4d {
namespace {

// 3.8's names of options pano4d passes that later versions renamed, with
// their later names, oldest first (from each release's option_manager.cc;
// tests/data/colmap_help/README.md).
const std::map<std::string, std::vector<std::string>>& Renames() {
  static const std::map<std::string, std::vector<std::string>> kRenames = {
      {"SiftExtraction.use_gpu", {"FeatureExtraction.use_gpu"}},
      {"SiftExtraction.num_threads", {"FeatureExtraction.num_threads"}},
      {"SiftExtraction.max_image_size", {"FeatureExtraction.max_image_size"}},
      {"SiftMatching.use_gpu", {"FeatureMatching.use_gpu"}},
      {"SiftMatching.num_threads", {"FeatureMatching.num_threads"}},
  };
  return kRenames;
}

}  // namespace

std::optional<ColmapVersion> ParseColmapVersion(std::string_view help) {
  static const std::regex kVersion(R"(COLMAP (\d+)\.(\d+)(?:\.(\d+))?)");
  std::istringstream lines{std::string(help)};
  for (std::string line; std::getline(lines, line);) {
    std::smatch m;
    if (!std::regex_search(line, m, kVersion)) continue;
    ColmapVersion v;
    v.major = std::stoi(m[1]);
    v.minor = std::stoi(m[2]);
    v.patch = m[3].matched ? std::stoi(m[3]) : 0;
    v.text = m[0].str().substr(7);
    return v;
  }
  return std::nullopt;
}

std::set<std::string> ParseColmapOptions(std::string_view help) {
  static const std::regex kOption(R"(^\s+--([A-Za-z0-9_.]+))");
  std::set<std::string> options;
  std::istringstream lines{std::string(help)};
  for (std::string line; std::getline(lines, line);) {
    std::smatch m;
    if (std::regex_search(line, m, kOption)) options.insert(m[1]);
  }
  return options;
}

std::string MapColmapOption(const std::string& option,
                            const std::string& command,
                            const std::set<std::string>& accepted,
                            const ColmapVersion& version) {
  if (accepted.count(option)) return option;
  std::string tried = "--" + option;
  if (const auto found = Renames().find(option); found != Renames().end()) {
    for (const std::string& name : found->second) {
      if (accepted.count(name)) return name;
      tried += " or --" + name;
    }
  }
  throw Error("colmap " + version.text, command, "--" + option,
              "`colmap " + command + " -h` lists no " + tried +
                  "; pano4d supports COLMAP " + kTestedColmapVersions);
}

bool CheckColmapVersion(const ColmapVersion& version) {
  if (version < kOldestColmap) {
    throw Error("colmap", "version", version.text,
                std::string("is older than pano4d supports (") +
                    kTestedColmapVersions +
                    "); install COLMAP 3.8 or later (Debian 12: apt-get "
                    "install colmap)");
  }
  return !(kNewestTestedColmap < version);
}

}  // namespace pano4d
