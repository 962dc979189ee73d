// Any bytes into the three COLMAP text readers. Only pano4d::Error may come
// out; what a reader accepts must write text that reads back to the same
// text, and survive binary unchanged.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "colmap_ext/model.h"
#include "colmap_ext/model_io_binary.h"
#include "colmap_ext/model_io_text.h"
#include "src/core/error.h"

namespace {

using pano4d::ColmapModel;
using Read = void (*)(ColmapModel&, std::istream&, const std::string&);
using Write = void (*)(const ColmapModel&, std::ostream&);

std::string Written(const ColmapModel& model, Write write) {
  std::ostringstream out;
  write(model, out);
  return out.str();
}

void RoundTrip(const std::string& text, Read read, Write write,
               Read read_binary, Write write_binary) {
  ColmapModel model;
  std::istringstream in(text);
  try {
    read(model, in, "fuzz.txt");
  } catch (const pano4d::Error&) {
    return;
  }
  try {
    model.Check();
  } catch (const pano4d::Error&) {
  }
  (void)model.Stats();

  // What was read can always be written, and the writing is a fixed point.
  const std::string first = Written(model, write);
  ColmapModel again;
  std::istringstream first_in(first);
  read(again, first_in, "first.txt");
  if (Written(again, write) != first) std::abort();

  std::string binary;
  try {
    binary = Written(model, write_binary);
  } catch (const pano4d::Error&) {
    return;  // a NUL in a name, which images.bin cannot hold
  }
  ColmapModel back;
  std::istringstream binary_in(binary);
  read_binary(back, binary_in, "fuzz.bin");
  if (Written(back, write) != first) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data,
                                      std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  RoundTrip(text, pano4d::ReadCamerasText, pano4d::WriteCamerasText,
            pano4d::ReadCamerasBinary, pano4d::WriteCamerasBinary);
  RoundTrip(text, pano4d::ReadImagesText, pano4d::WriteImagesText,
            pano4d::ReadImagesBinary, pano4d::WriteImagesBinary);
  RoundTrip(text, pano4d::ReadPoints3DText, pano4d::WritePoints3DText,
            pano4d::ReadPoints3DBinary, pano4d::WritePoints3DBinary);
  return 0;
}
