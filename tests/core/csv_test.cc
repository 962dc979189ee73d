#include "src/core/csv.h"

#include <gtest/gtest.h>

namespace pano4d {
namespace {

// RFC 4180: plain fields as they are; a comma, quote or line break quoted,
// with the quotes inside doubled (the sweep table replaced them by
// apostrophes, and bench datasets turned line breaks into spaces).
TEST(CsvTest, FieldsAreQuotedOnlyWhenTheyMustBe) {
  EXPECT_EQ(CsvField("balloon1"), "balloon1");
  EXPECT_EQ(CsvField(""), "");
  EXPECT_EQ(CsvField("a,b"), "\"a,b\"");
  EXPECT_EQ(CsvField("say \"no\""), "\"say \"\"no\"\"\"");
  EXPECT_EQ(CsvField("two\nlines"), "\"two\nlines\"");
  EXPECT_EQ(CsvRow({"scene", "", "x,y"}), "scene,,\"x,y\"\n");
}

}  // namespace
}  // namespace pano4d
