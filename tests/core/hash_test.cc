#include "src/core/hash.h"

#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

std::string HexOf(std::string_view bytes) {
  Hash64 h;
  h.Add(bytes);
  return h.Hex();
}

TEST(HashTest, PiecesFedInAnySplitHashAsTheWhole) {
  const std::string text = "the quick brown fox jumps over the lazy dog 0123";
  for (std::size_t cut = 0; cut <= text.size(); ++cut) {
    for (std::size_t cut2 = cut; cut2 <= text.size(); cut2 += 5) {
      Hash64 h;
      h.Add(std::string_view(text).substr(0, cut));
      h.Add(std::string_view(text).substr(cut, cut2 - cut));
      h.Add(std::string_view(text).substr(cut2));
      ASSERT_EQ(h.Hex(), HexOf(text)) << cut << " " << cut2;
    }
  }
  EXPECT_EQ(HexOf(text).size(), 16u);
}

TEST(HashTest, EveryFlippedBitAndEveryLengthGivesAnotherValue) {
  std::string bytes(64, '\0');
  std::set<std::string> seen = {HexOf(bytes)};
  for (std::size_t i = 0; i < bytes.size() * 8; ++i) {
    std::string flipped = bytes;
    flipped[i / 8] ^= static_cast<char>(1 << (i % 8));
    EXPECT_TRUE(seen.insert(HexOf(flipped)).second) << "bit " << i;
  }
  // Trailing zero bytes change the value (the length is hashed).
  for (std::size_t n = 0; n < 20; ++n)
    EXPECT_TRUE(seen.insert(HexOf(std::string(n, '\0'))).second) << n;
}

TEST(HashTest, StringsAreDelimited) {
  Hash64 a, b;
  a.AddString("ab");
  a.AddString("c");
  b.AddString("a");
  b.AddString("bc");
  EXPECT_NE(a.value(), b.value());
}

TEST(HashTest, FileHashIsTheHashOfItsBytesAndNamesAMissingFile) {
  testing::TempDir dir;
  const std::filesystem::path path = dir.path() / "f.bin";
  std::string bytes(3 << 20, 'x');
  bytes[12345] = 'y';
  std::ofstream(path, std::ios::binary) << bytes;
  EXPECT_EQ(HashFileHex(path), HexOf(bytes));
  try {
    HashFileHex(dir.path() / "missing.bin");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.bin"), std::string::npos);
  }
}

}  // namespace
}  // namespace pano4d
