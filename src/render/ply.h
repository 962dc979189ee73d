#pragma once

#include <filesystem>
#include <iosfwd>
#include <string>

#include "src/render/gaussians.h"

namespace pano4d {

// 3D Gaussian splatting's PLY layout, which common splat viewers open:
//   format binary_little_endian 1.0, one element "vertex" with float
//   properties x y z, nx ny nz (zero), f_dc_0..2, f_rest_0..(3 (K - 1) - 1),
//   opacity (logit), scale_0..2 (log), rot_0..3 (w x y z, as stored).
// f_rest is channel-major: all red higher-order coefficients, then green,
// then blue; pano4d's GaussianModel keeps them coefficient-major.

void WritePly(std::ostream& out, const GaussianModel& model);
void WritePly(const std::filesystem::path& path,
              const GaussianModel& model);  // atomic

// Reads the layout above, properties in any order (others ignored), the SH
// degree from the number of f_rest properties (0, 9, 24 or 45). Throws
// pano4d::Error naming `source` for ASCII or big-endian files, missing
// properties, non-float types, or a vertex count the file does not hold
// (checked before allocating). The stream must be seekable (a file or a
// string stream), for that check.
GaussianModel ReadPly(std::istream& in, const std::string& source);
GaussianModel ReadPly(const std::filesystem::path& path);

}  // namespace pano4d
