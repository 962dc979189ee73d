#pragma once

#include <filesystem>
#include <istream>
#include <ostream>
#include <string>

#include "colmap_ext/model.h"

namespace pano4d {

// COLMAP 3.8's text model files (cameras.txt, images.txt, points3D.txt). The
// writers produce the bytes `colmap model_converter --output_type TXT`
// writes for the same model in the same order: COLMAP's header comments with
// its counts and means, numbers as C++ streams print them at precision 17
// ("%.17g"), invalid 3D point ids as -1, no trailing spaces.
//
// Each Read replaces one list of `model` in file order and rebuilds the
// index; it does not Check() the model. Comment lines (#) and empty lines
// are skipped, except that the line after an image line is always its
// POINTS2D line, possibly empty. Tokens are separated by any run of blanks,
// and an image name is the rest of its line (COLMAP keeps only the first
// word), so names with spaces survive a round trip.
//
// A malformed line throws pano4d::Error whose source is "SOURCE:LINE", with
// the field and the token found there, e.g.
//   images.txt:12: field 'image 3 QW' = "abc": expected a real number.
// The writers throw pano4d::Error for what the reader could not give back:
// an unknown model id, a parameter count that does not match the model, an
// image name with a line break or with blanks at either end.
void ReadCamerasText(ColmapModel& model, std::istream& stream,
                     const std::string& source = "cameras.txt");
void ReadCamerasText(ColmapModel& model, const std::filesystem::path& path);
void ReadImagesText(ColmapModel& model, std::istream& stream,
                    const std::string& source = "images.txt");
void ReadImagesText(ColmapModel& model, const std::filesystem::path& path);
void ReadPoints3DText(ColmapModel& model, std::istream& stream,
                      const std::string& source = "points3D.txt");
void ReadPoints3DText(ColmapModel& model, const std::filesystem::path& path);

// images.txt and points3D.txt headers carry model-wide means, so each
// writer takes the whole model.
void WriteCamerasText(const ColmapModel& model, std::ostream& stream);
void WriteCamerasText(const ColmapModel& model,
                      const std::filesystem::path& path);
void WriteImagesText(const ColmapModel& model, std::ostream& stream);
void WriteImagesText(const ColmapModel& model,
                     const std::filesystem::path& path);
void WritePoints3DText(const ColmapModel& model, std::ostream& stream);
void WritePoints3DText(const ColmapModel& model,
                       const std::filesystem::path& path);

}  // namespace pano4d
