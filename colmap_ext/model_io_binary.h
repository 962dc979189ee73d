#pragma once

#include <filesystem>
#include <istream>
#include <ostream>
#include <string>

#include "colmap_ext/model.h"

namespace pano4d {

// COLMAP 3.8's binary model files (cameras.bin, images.bin, points3D.bin),
// little-endian. Each Read replaces one list of `model` with the file's
// entries in file order and rebuilds the index; it does not Check() the
// model. Writing what was read gives back the same bytes.
//
// A malformed stream throws pano4d::Error naming `source`, the field (e.g.
// "image 12 name") and the byte offset: where a truncated file ends, where
// bytes are left over after the last entry, or which count cannot fit in
// the bytes that remain. Counts are checked against the stream's size before
// anything is allocated, so no input makes the reader allocate much more
// than its own size. Model ids COLMAP 3.8 does not define are refused.
//
// The path overloads open the file (source = the path) and write atomically.
// The writers throw pano4d::Error for what the format cannot hold (an unknown
// model id, a parameter count that does not match the model, a NUL in an
// image name) or when the stream fails.
void ReadCamerasBinary(ColmapModel& model, std::istream& stream,
                       const std::string& source = "cameras.bin");
void ReadCamerasBinary(ColmapModel& model, const std::filesystem::path& path);
void ReadImagesBinary(ColmapModel& model, std::istream& stream,
                      const std::string& source = "images.bin");
void ReadImagesBinary(ColmapModel& model, const std::filesystem::path& path);
void ReadPoints3DBinary(ColmapModel& model, std::istream& stream,
                        const std::string& source = "points3D.bin");
void ReadPoints3DBinary(ColmapModel& model, const std::filesystem::path& path);

void WriteCamerasBinary(const ColmapModel& model, std::ostream& stream);
void WriteCamerasBinary(const ColmapModel& model,
                        const std::filesystem::path& path);
void WriteImagesBinary(const ColmapModel& model, std::ostream& stream);
void WriteImagesBinary(const ColmapModel& model,
                       const std::filesystem::path& path);
void WritePoints3DBinary(const ColmapModel& model, std::ostream& stream);
void WritePoints3DBinary(const ColmapModel& model,
                         const std::filesystem::path& path);

}  // namespace pano4d
