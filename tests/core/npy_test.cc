#include "src/core/npy.h"

#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/file.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

// Fixtures written by NumPy 1.24 (tests/data/npy/make_fixtures.py).
std::filesystem::path Fixture(const std::string& name) {
  return std::filesystem::path(PANO4D_SOURCE_DIR) / "tests/data/npy" / name;
}

std::string ErrorOf(const std::string& bytes) {
  try {
    ParseNpy(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size(),
             "x.npy");
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

// A version 1.0 file with the given header text and `data_bytes` zero bytes.
std::string FileWithHeader(const std::string& header, std::size_t data_bytes) {
  std::string file = "\x93NUMPY";
  file += '\x01';
  file += '\x00';
  file += static_cast<char>(header.size() & 0xff);
  file += static_cast<char>(header.size() >> 8);
  file += header;
  file += std::string(data_bytes, '\0');
  return file;
}

TEST(NpyTest, ReadsWhatNumPyWrites) {
  const NpyArray f4 = ReadNpy(Fixture("f4_2x3.npy"));
  EXPECT_EQ(f4.descr(), "<f4");
  EXPECT_EQ(f4.shape, (std::vector<std::int64_t>{2, 3}));
  EXPECT_EQ(f4.ToFloats(), (std::vector<float>{0, 0.25, 0.5, 0.75, 1, 1.25}));

  const NpyArray be = ReadNpy(Fixture("f8_big_endian.npy"));
  EXPECT_EQ(be.ToDoubles(), (std::vector<double>{1.5, -2.25, 1e300}));

  const NpyArray u1 = ReadNpy(Fixture("u1_2x3x2.npy"));
  EXPECT_EQ(u1.shape, (std::vector<std::int64_t>{2, 3, 2}));
  EXPECT_EQ(u1.ToDoubles()[11], 11.0);

  const NpyArray scalar = ReadNpy(Fixture("i8_scalar.npy"));
  EXPECT_TRUE(scalar.shape.empty());
  EXPECT_EQ(scalar.size(), 1);
  EXPECT_EQ(scalar.ToDoubles(), (std::vector<double>{-7}));

  EXPECT_EQ(ReadNpy(Fixture("bool_1d.npy")).ToDoubles(),
            (std::vector<double>{1, 0, 1}));
  EXPECT_EQ(ReadNpy(Fixture("i2_v2.npy")).ToDoubles(),
            (std::vector<double>{-3, 4}));

  const NpyArray poses = ReadNpy(Fixture("poses_bounds_2x17.npy"));
  EXPECT_EQ(poses.shape, (std::vector<std::int64_t>{2, 17}));
  EXPECT_EQ(poses.ToDoubles()[33], 16.5);
}

TEST(NpyTest, WritesByteForByteWhatNumPyWrites) {
  const NpyArray array =
      NpyArray::FromFloats({2, 3}, {0, 0.25, 0.5, 0.75, 1, 1.25});
  std::ostringstream out;
  WriteNpy(out, array);
  EXPECT_EQ(out.str(), ReadTextFile(Fixture("f4_2x3.npy")));
}

TEST(NpyTest, FileRoundTrip) {
  testing::TempDir dir;
  const NpyArray depth =
      NpyArray::FromFloats({2, 2, 1}, {0, 1.5f, 2.5f, 1e-3f});
  WriteNpy(dir / "depth.npy", depth);
  const NpyArray back = ReadNpy(dir / "depth.npy");
  EXPECT_EQ(back.shape, depth.shape);
  EXPECT_EQ(back.data, depth.data);
  EXPECT_EQ(NpyArray::FromDoubles({0}, {}).size(), 0);
  EXPECT_THROW(NpyArray::FromDoubles({3}, {1, 2}), Error);
}

TEST(NpyTest, RejectsUnsupportedArraysWithTheReason) {
  EXPECT_NE(
      ErrorOf(ReadTextFile(Fixture("f8_fortran.npy"))).find("Fortran-order"),
      std::string::npos);
  EXPECT_NE(ErrorOf(ReadTextFile(Fixture("c8_complex.npy")))
                .find("unsupported dtype"),
            std::string::npos);
}

TEST(NpyTest, RejectsMalformedHeaders) {
  const std::string good =
      "{'descr': '<f4', 'fortran_order': False, 'shape': (2,), }\n";
  EXPECT_EQ(ErrorOf(FileWithHeader(good, 8)), "no error");
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"{'descr': '<f4', 'shape': (2,), }", "must hold"},
      {"{'descr': '<f4', 'fortran_order': False, 'shape': (2,), 'x': 1}",
       "unexpected key"},
      {"{'descr': '<f4', 'descr': '<f4', 'fortran_order': False, 'shape': "
       "(2,)}",
       "duplicate"},
      {"{'descr': '<f4', 'fortran_order': False, 'shape': (2)}", "tuple"},
      {"{'descr': '<f4', 'fortran_order': False, 'shape': (-2,)}",
       "non-negative"},
      {"{'descr': '<f4', 'fortran_order': Maybe, 'shape': (2,)}",
       "True or False"},
      {"{'descr': '<f4, 'fortran_order': False, 'shape': (2,)}", "malformed"},
      {"{'descr': '<f3', 'fortran_order': False, 'shape': (2,)}",
       "unsupported dtype"},
      {"{'descr': '<f4', 'fortran_order': False, 'shape': (2,)} junk",
       "after the header"},
      {"{'descr': '<f4', 'fortran_order': False, 'shape': "
       "(99999999999999999999,)}",
       "too large"},
  };
  for (const auto& [header, reason] : bad) {
    const std::string message = ErrorOf(FileWithHeader(header, 8));
    EXPECT_EQ(message.rfind("x.npy: ", 0), 0u) << header;
    EXPECT_NE(message.find(reason), std::string::npos)
        << header << " -> " << message;
  }
}

TEST(NpyTest, SizeMismatchIsCaughtBeforeAllocating) {
  // 2^61 elements announced in a 100-byte file: an error, not an allocation.
  const std::string huge =
      "{'descr': '<f8', 'fortran_order': False, 'shape': "
      "(2305843009213693952,), }";
  EXPECT_NE(
      ErrorOf(FileWithHeader(huge, 16)).find("more data than the file holds"),
      std::string::npos);
  const std::string header =
      "{'descr': '<f4', 'fortran_order': False, 'shape': (2,), }";
  EXPECT_NE(
      ErrorOf(FileWithHeader(header, 7)).find("more data than the file holds"),
      std::string::npos);
  EXPECT_NE(ErrorOf(FileWithHeader(header, 9)).find("9 follow the header"),
            std::string::npos);

  const std::string file = ReadTextFile(Fixture("f4_2x3.npy"));
  EXPECT_NE(ErrorOf(file.substr(0, 50)).find("truncated"), std::string::npos);
  EXPECT_NE(ErrorOf("PK\x03\x04 a zip file").find("not a .npy file"),
            std::string::npos);
  std::string bad_version = file;
  bad_version[6] = 9;
  EXPECT_NE(ErrorOf(bad_version).find("unsupported .npy format version"),
            std::string::npos);
  std::string long_header = file;
  long_header[6] = 2;  // version 2 reads a 4-byte length: here about 2^30
  long_header[10] = 0x10;
  long_header[11] = 0x40;
  EXPECT_NE(ErrorOf(long_header).find("implausible"), std::string::npos);
}

}  // namespace
}  // namespace pano4d
