#include "src/core/npz.h"

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/file.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

using testing::TempDir;

NpzArrays TwoArrays() {
  NpzArrays arrays;
  arrays["flow"] = NpyArray::FromFloats({2, 3, 2}, {0, 1, 2, 3, 4, 5, 6, 7, 8,
                                                    9, 10, 11});
  NpyArray mask;
  mask.kind = 'b';
  mask.item_size = 1;
  mask.shape = {2, 3};
  mask.data = {1, 0, 1, 1, 0, 1};
  arrays["mask"] = mask;
  return arrays;
}

TEST(NpzTest, StoredAndDeflatedArchivesReadBack) {
  const TempDir dir;
  for (const bool compressed : {false, true}) {
    const auto path = dir / (compressed ? "c.npz" : "s.npz");
    WriteNpz(path, TwoArrays(), compressed);
    const NpzArrays back = ReadNpz(path);
    ASSERT_EQ(back.size(), 2u);
    EXPECT_EQ(back.at("flow").shape, (std::vector<std::int64_t>{2, 3, 2}));
    EXPECT_EQ(back.at("flow").ToFloats()[11], 11.0f);
    EXPECT_EQ(back.at("mask").ToDoubles(),
              (std::vector<double>{1, 0, 1, 1, 0, 1}));
  }
}

TEST(NpzTest, Float16RoundsToTheNearestHalf) {
  const TempDir dir;
  NpzArrays arrays;
  arrays["flow"] = NpyArray::FromFloatsAsHalves({3}, {0.5f, -2.0f, 1.0001f});
  EXPECT_EQ(arrays["flow"].descr(), "<f2");
  WriteNpz(dir / "h.npz", arrays, true);
  EXPECT_EQ(ReadNpz(dir / "h.npz").at("flow").ToFloats(),
            (std::vector<float>{0.5f, -2.0f, 1.0f}));
}

TEST(NpzTest, CorruptArchivesAndMissingKeysNameTheFile) {
  const TempDir dir;
  const auto path = dir / "x.npz";
  WriteNpz(path, TwoArrays(), true);
  std::vector<std::uint8_t> bytes = ReadFileBytes(path);
  // Truncated: the central directory is gone.
  try {
    ParseNpz(bytes.data(), bytes.size() / 2, "x.npz");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("x.npz"), std::string::npos);
  }
  // Not a zip at all.
  const std::string text = "not a zip";
  EXPECT_THROW(ParseNpz(reinterpret_cast<const std::uint8_t*>(text.data()),
                        text.size(), "t.npz"),
               Error);
  const NpzArrays arrays = ReadNpz(path);
  try {
    NpzArray(arrays, "dep", "x.npz");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("flow, mask"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace pano4d
