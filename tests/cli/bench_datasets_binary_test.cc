// `pano4d bench datasets` on a root of two tiny synthetic scenes and a
// broken one: the table has a row per scene (the broken one with its error,
// the others with metrics), the exit status says a scene failed, and a
// second run reads the finished scenes back instead of fitting them again.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;
using testing::Slurp;

using testing::RunPano4d;

TEST(BenchDatasetsTest, EverySceneIsARowAndASecondRunResumes) {
  testing::TempDir dir;
  const fs::path root = dir / "root";
  const fs::path log = dir / "bench.log";
  for (const char* seed : {"5", "6"}) {
    ASSERT_EQ(
        RunPano4d(std::string("synth --preset tiny --seed ") + seed +
                      " --out '" +
                      (root / ("tiny" + std::string(seed))).string() + "'",
                  log),
        0)
        << Slurp(log);
  }
  // A scene whose first training frame is cut short.
  fs::copy(root / "tiny5", root / "broken", fs::copy_options::recursive);
  testing::WriteTruncatedPng(root / "broken/rgb/2x/0_00000.png");
  fs::create_directories(root / "notes");  // no dataset: not a scene

  const fs::path ws = dir / "bench";
  const std::string bench = "bench datasets --root '" + root.string() +
                            "' --iterations 20 --workspace '" + ws.string() +
                            "'";
  EXPECT_EQ(RunPano4d(bench, log), 1) << Slurp(log);
  const std::string md = Slurp(ws / "datasets.md");
  for (const char* scene :
       {"| tiny5 | synth | pano4d |", "| tiny6 | synth | pano4d |",
        "| broken | synth | pano4d: failed:"})
    EXPECT_NE(md.find(scene), std::string::npos) << scene << "\n" << md;
  EXPECT_NE(md.find("0_00000.png"), std::string::npos) << md;  // the error
  EXPECT_NE(md.find("mean (2 of 3 scenes)"), std::string::npos) << md;
  EXPECT_EQ(md.find("notes"), std::string::npos) << md;
  const std::string csv = Slurp(ws / "datasets.csv");
  EXPECT_EQ(csv.rfind("scene,suite,method,source,status,error,psnr", 0), 0u)
      << csv;
  EXPECT_NE(csv.find("tiny6,synth,pano4d,pano4d,done,,"), std::string::npos)
      << csv;

  std::ifstream entry_file(ws / "tiny5/pano4d/bench_entry.json");
  const nlohmann::json entry = nlohmann::json::parse(entry_file);
  EXPECT_EQ(entry["status"], "done");
  EXPECT_TRUE(entry["metrics"]["psnr"].is_number());
  EXPECT_GT(entry["seconds"].get<double>(), 0.0);
  EXPECT_GT(entry["peak_memory_mib"].get<double>(), 1.0);

  // Again, on the two good scenes: nothing is fitted, the rows are the same.
  const auto checkpoint = ws / "tiny5/pano4d/checkpoints/fit.ckpt";
  ASSERT_TRUE(fs::exists(checkpoint));
  const auto written = fs::last_write_time(checkpoint);
  EXPECT_EQ(RunPano4d(bench + " --scenes tiny5,tiny6", log), 0) << Slurp(log);
  EXPECT_NE(Slurp(log).find("complete from an earlier run"), std::string::npos)
      << Slurp(log);
  EXPECT_EQ(fs::last_write_time(checkpoint), written);
  const std::string again = Slurp(ws / "datasets.md");
  const auto row = [](const std::string& table, const std::string& scene) {
    const auto at = table.find("| " + scene + " | synth | pano4d |");
    return table.substr(at, table.find('\n', at) - at);
  };
  EXPECT_EQ(row(again, "tiny5"), row(md, "tiny5"));

  // A scene name that is not there is an error naming it.
  EXPECT_EQ(RunPano4d(bench + " --scenes tiny7", log), 1);
  EXPECT_NE(Slurp(log).find("tiny7"), std::string::npos) << Slurp(log);
}

}  // namespace
}  // namespace pano4d
