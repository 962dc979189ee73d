#pragma once

#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

namespace pano4d {

// A NumPy .npy array (format versions 1.0, 2.0 and 3.0). Only C-order arrays
// of plain numeric types are supported: bool, int8..int64, uint8..uint64,
// float16 (MoSca's flow files), float32, float64, in either byte order.
// Data are held in this machine's (little-endian) byte order, whatever the
// file's.
struct NpyArray {
  char kind = 'f';    // 'f' float, 'i' signed, 'u' unsigned, 'b' bool
  int item_size = 4;  // bytes per element
  std::vector<std::int64_t> shape;
  std::vector<std::uint8_t> data;  // size() * item_size bytes, C order

  std::int64_t size() const;  // number of elements (1 for a 0-d array)
  // NumPy's descr for this dtype, e.g. "<f4", "|u1".
  std::string descr() const;

  // The elements converted to double / float, in C order.
  std::vector<double> ToDoubles() const;
  std::vector<float> ToFloats() const;

  static NpyArray FromFloats(std::vector<std::int64_t> shape,
                             const std::vector<float>& values);
  static NpyArray FromDoubles(std::vector<std::int64_t> shape,
                              const std::vector<double>& values);
  // float16 ('<f2'), each value rounded to the nearest half.
  static NpyArray FromFloatsAsHalves(std::vector<std::int64_t> shape,
                                     const std::vector<float>& values);
};

// Guards against corrupt headers: a header may not be longer than this, and
// the data size a header announces must match the bytes that follow it, so
// a corrupt shape can never trigger a huge allocation.
inline constexpr std::size_t kMaxNpyHeaderBytes = 1 << 20;

// Throw pano4d::Error naming `source` and what is wrong (bad magic, unknown
// version, malformed header dict, unsupported dtype, Fortran order, data size
// that does not match the shape).
NpyArray ReadNpy(std::istream& in, const std::string& source);
NpyArray ReadNpy(const std::filesystem::path& path);
NpyArray ParseNpy(const std::uint8_t* bytes, std::size_t size,
                  const std::string& source);

// Writes format 1.0 (2.0 when the header needs it), header padded to 64
// bytes as NumPy does. The path overload writes atomically.
void WriteNpy(std::ostream& out, const NpyArray& array);
void WriteNpy(const std::filesystem::path& path, const NpyArray& array);

}  // namespace pano4d
