// datasets_meta/*.json feed the reports' "paper" rows: every file must keep
// the schema in datasets_meta/README.md, or a report would silently miss rows.
#include <set>

#include <gtest/gtest.h>

#include "src/core/json.h"

namespace pano4d {
namespace {

const std::filesystem::path kMeta =
    std::filesystem::path(PANO4D_SOURCE_DIR) / "datasets_meta";

void ExpectRowsHaveColumns(const Json& table, const std::string& label_key,
                           const std::string& where) {
  const std::vector<std::string> columns =
      table.at("columns").get<std::vector<std::string>>();
  ASSERT_FALSE(columns.empty()) << where;
  ASSERT_FALSE(table.at("rows").empty()) << where;
  for (const Json& row : table.at("rows")) {
    EXPECT_TRUE(row.contains(label_key)) << where << ": " << row.dump();
    for (const std::string& column : columns) {
      ASSERT_TRUE(row.contains(column))
          << where << ": row lacks " << column << ": " << row.dump();
      EXPECT_TRUE(row[column].is_number() || row[column].is_null())
          << where << ": " << row.dump();
    }
  }
}

TEST(DatasetsMetaTest, BenchmarkFilesKeepTheSchema) {
  const std::set<std::string> metric_keys = {"psnr",  "ssim",  "lpips",
                                             "mpsnr", "mssim", "mlpips",
                                             "upsnr", "ussim", "ulpips"};
  for (const char* name :
       {"dycheck_iphone", "nvidia_dynamic_scenes", "kubric4d"}) {
    const auto path = kMeta / (std::string(name) + ".json");
    const Json meta = ReadJson(path);
    for (const char* key : {"benchmark", "description", "scenes", "resolution",
                            "protocol", "paper"}) {
      EXPECT_TRUE(meta.contains(key)) << path << " lacks " << key;
    }
    EXPECT_FALSE(meta["scenes"].empty()) << path;
    ASSERT_TRUE(meta["paper"].is_object()) << path;
    ExpectRowsHaveColumns(meta["paper"], "method", path.string());
    int ours = 0;
    for (const Json& row : meta["paper"]["rows"])
      ours += row.value("ours", false) ? 1 : 0;
    EXPECT_EQ(ours, 1) << path << ": exactly one row must be marked \"ours\"";
    for (const std::string& column :
         meta["paper"]["columns"].get<std::vector<std::string>>()) {
      EXPECT_TRUE(metric_keys.count(column))
          << path << ": unknown metric column " << column;
    }
  }
}

TEST(DatasetsMetaTest, DyCheckRowOfThePaperIsTranscribed) {
  // Table 1 of the paper, PanoGaussian's row (the LaTeX in shared/seed).
  const Json meta = ReadJson(kMeta / "dycheck_iphone.json");
  const Json* ours = nullptr;
  for (const Json& row : meta["paper"]["rows"]) {
    if (row.value("ours", false)) ours = &row;
  }
  ASSERT_NE(ours, nullptr);
  EXPECT_DOUBLE_EQ((*ours)["psnr"].get<double>(), 18.71);
  EXPECT_DOUBLE_EQ((*ours)["mpsnr"].get<double>(), 19.85);
  EXPECT_DOUBLE_EQ((*ours)["upsnr"].get<double>(), 16.72);
  EXPECT_DOUBLE_EQ((*ours)["ulpips"].get<double>(), 0.385);
}

TEST(DatasetsMetaTest, AblationTablesKeepTheSchema) {
  const Json ablations = ReadJson(kMeta / "ablations.json");
  ASSERT_TRUE(ablations.contains("tables"));
  ASSERT_GE(ablations["tables"].size(), 2u);
  for (const Json& table : ablations["tables"]) {
    ExpectRowsHaveColumns(table, "setting", table.value("ablation", "?"));
  }
}

}  // namespace
}  // namespace pano4d
