// Any bytes into the three COLMAP binary readers. Only pano4d::Error may come
// out; what a reader accepts must write back to the same bytes and come
// through text unchanged (up to NaN payloads, which text does not keep).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>

#include "colmap_ext/model.h"
#include "colmap_ext/model_io_binary.h"
#include "colmap_ext/model_io_text.h"
#include "src/core/error.h"

namespace {

using pano4d::ColmapModel;

bool Same(double a, double b) {
  return std::memcmp(&a, &b, sizeof(double)) == 0 ||
         (std::isnan(a) && std::isnan(b));
}

bool SameModel(const ColmapModel& a, const ColmapModel& b) {
  if (a.cameras.size() != b.cameras.size() ||
      a.images.size() != b.images.size() ||
      a.points3D.size() != b.points3D.size()) {
    return false;
  }
  for (std::size_t i = 0; i < a.cameras.size(); ++i) {
    const auto &x = a.cameras[i], &y = b.cameras[i];
    if (x.camera_id != y.camera_id || x.model_id != y.model_id ||
        x.width != y.width || x.height != y.height ||
        x.params.size() != y.params.size()) {
      return false;
    }
    for (std::size_t k = 0; k < x.params.size(); ++k) {
      if (!Same(x.params[k], y.params[k])) return false;
    }
  }
  for (std::size_t i = 0; i < a.images.size(); ++i) {
    const auto &x = a.images[i], &y = b.images[i];
    if (x.image_id != y.image_id || x.camera_id != y.camera_id ||
        x.name != y.name || x.points2D.size() != y.points2D.size()) {
      return false;
    }
    for (int k = 0; k < 4; ++k) {
      if (!Same(x.qvec(k), y.qvec(k))) return false;
    }
    for (int k = 0; k < 3; ++k) {
      if (!Same(x.tvec(k), y.tvec(k))) return false;
    }
    for (std::size_t j = 0; j < x.points2D.size(); ++j) {
      if (!Same(x.points2D[j].xy.x(), y.points2D[j].xy.x()) ||
          !Same(x.points2D[j].xy.y(), y.points2D[j].xy.y()) ||
          x.points2D[j].point3D_id != y.points2D[j].point3D_id) {
        return false;
      }
    }
  }
  for (std::size_t i = 0; i < a.points3D.size(); ++i) {
    const auto &x = a.points3D[i], &y = b.points3D[i];
    if (x.point3D_id != y.point3D_id || x.rgb != y.rgb ||
        !Same(x.error, y.error) || x.track != y.track) {
      return false;
    }
    for (int k = 0; k < 3; ++k) {
      if (!Same(x.xyz(k), y.xyz(k))) return false;
    }
  }
  return true;
}

using Read = void (*)(ColmapModel&, std::istream&, const std::string&);
using Write = void (*)(const ColmapModel&, std::ostream&);

void RoundTrip(const std::string& bytes, Read read, Write write, Read read_text,
               Write write_text) {
  ColmapModel model;
  std::istringstream in(bytes);
  try {
    read(model, in, "fuzz.bin");
  } catch (const pano4d::Error&) {
    return;
  }
  try {
    model.Check();
  } catch (const pano4d::Error&) {
  }
  (void)model.Stats();

  std::ostringstream out;
  write(model, out);  // what was read can always be written
  if (out.str() != bytes) std::abort();

  std::ostringstream text;
  try {
    write_text(model, text);
  } catch (const pano4d::Error&) {
    return;  // a name that text cannot hold (a line break, outer blanks)
  }
  ColmapModel back;
  std::istringstream text_in(text.str());
  read_text(back, text_in, "fuzz.txt");
  if (!SameModel(model, back)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  RoundTrip(bytes, pano4d::ReadCamerasBinary, pano4d::WriteCamerasBinary,
            pano4d::ReadCamerasText, pano4d::WriteCamerasText);
  RoundTrip(bytes, pano4d::ReadImagesBinary, pano4d::WriteImagesBinary,
            pano4d::ReadImagesText, pano4d::WriteImagesText);
  RoundTrip(bytes, pano4d::ReadPoints3DBinary, pano4d::WritePoints3DBinary,
            pano4d::ReadPoints3DText, pano4d::WritePoints3DText);
  return 0;
}
