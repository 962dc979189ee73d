#pragma once

// `pano4d inspect`: what pano4d reads from a file (image, video, camera
// JSON, any JSON), through the same functions as the pipeline, so that a
// file inspect rejects is one the pipeline rejects, with the same message.

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

namespace pano4d {

// `as`: auto (by extension), image, video, camera or json. `count_frames`
// decodes a whole video (containers may misreport their frame count).
// Throws pano4d::Error naming the file.
nlohmann::json Inspect(const std::filesystem::path& path, const std::string& as,
                       bool count_frames);

}  // namespace pano4d
