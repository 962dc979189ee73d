// pano4d's COLMAP command lines against the help outputs of COLMAP 3.8 to
// 4.1 (tests/data/colmap_help/, README there says where each came from):
// a fake `colmap` per version prints that version's help and refuses any
// option the version does not list, as COLMAP's option parser does.
#include "colmap_ext/colmap_options.h"

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "colmap_ext/colmap_commands.h"
#include "colmap_ext/colmap_runner.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/subprocess.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;

const fs::path kFixtures =
    fs::path(PANO4D_SOURCE_DIR) / "tests" / "data" / "colmap_help";

// A `colmap` that answers from `fixtures`: help, `<command> -h` (on stderr
// from 3.9 on, as the real ones), and runs that exit 0 when every --option
// is one the command lists, recording the command line in `record`.
fs::path FakeColmap(const fs::path& dir, const fs::path& fixtures,
                    bool help_on_stderr) {
  const fs::path path = dir / "colmap";
  std::ofstream(path)
      << "#!/bin/sh\n"
      << "F='" << fixtures.string() << "'\n"
      << "if [ \"$1\" = help ] || [ \"$1\" = -h ]; then cat \"$F/help.txt\"; "
         "exit 0; fi\n"
      << "cmd=$1; shift\n"
      << "[ -f \"$F/$cmd.txt\" ] || { echo \"unknown command $cmd\" >&2; exit "
         "1; }\n"
      << "if [ \"$1\" = -h ]; then cat \"$F/$cmd.txt\""
      << (help_on_stderr ? " >&2" : "") << "; exit 0; fi\n"
      << "for a in \"$@\"; do case \"$a\" in --*)\n"
      << "  awk -v o=\"$a\" '$1 == o { found = 1 } END { exit !found }' "
         "\"$F/$cmd.txt\" ||\n"
      << "    { echo \"Failed to parse options - unrecognised option '$a'\" "
         ">&2; exit 1; } ;;\n"
      << "esac; done\n"
      << "echo \"$cmd $*\" >> '" << (dir / "record.txt").string() << "'\n";
  fs::permissions(path, fs::perms::owner_all);
  return path;
}

// Every command line `pano4d sfm` runs, with every optional part present.
void RunEverySfmCommand(const ColmapRunner& colmap, const fs::path& logs) {
  FeatureExtractorSettings s;
  s.database = "db.db";
  s.images = "images";
  s.camera_model = "PINHOLE";
  s.single_camera = true;
  s.masks = "masks";
  s.image_list = "list.txt";
  s.camera_params = "100,100,32,24";
  colmap.Run("feature_extractor", FeatureExtractorArgs(s),
             logs / "feature_extractor.log");
  colmap.Run("exhaustive_matcher", MatcherArgs("db.db"),
             logs / "exhaustive_matcher.log");
  colmap.Run("sequential_matcher", MatcherArgs("db.db"),
             logs / "sequential_matcher.log");
  colmap.Run("mapper", MapperArgs("db.db", "images", "sparse"),
             logs / "mapper.log");
  colmap.Run("point_triangulator",
             PointTriangulatorArgs("db.db", "images", "in", "out"),
             logs / "point_triangulator.log");
  colmap.Run("image_undistorter", ImageUndistorterArgs("images", "in", "out"),
             logs / "image_undistorter.log");
}

class ColmapVersionsTest : public ::testing::TestWithParam<std::string> {};

TEST_P(ColmapVersionsTest, EverySfmCommandRunsWithThisVersionsNames) {
  const std::string version = GetParam();
  testing::TempDir dir;
  const ColmapRunner colmap(
      FakeColmap(dir.path(), kFixtures / version, version != "3.8"));
  RunEverySfmCommand(colmap, dir / "logs");
  EXPECT_EQ(colmap.Version(dir / "logs").text.rfind(version, 0), 0u)
      << colmap.Version(dir / "logs").text;
  const std::string record = ReadTextFile(dir / "record.txt");
  const bool renamed =
      !(colmap.Version(dir / "logs") < ColmapVersion{3, 13, 0, "3.13"});
  for (const char* group : {"Extraction.use_gpu", "Matching.use_gpu"}) {
    EXPECT_NE(
        record.find(std::string(renamed ? "--Feature" : "--Sift") + group),
        std::string::npos)
        << version << ": " << record;
    EXPECT_EQ(
        record.find(std::string(renamed ? "--Sift" : "--Feature") + group),
        std::string::npos)
        << version << ": " << record;
  }
  // The fake is as strict as COLMAP: 3.8's name, unmapped, fails where
  // the version renamed it.
  const fs::path fake = dir / "colmap";
  const ProcessResult unmapped = RunProcess(
      {fake.string(), "feature_extractor", "--SiftExtraction.use_gpu", "0"},
      dir / "unmapped.log");
  EXPECT_EQ(unmapped.ok(), !renamed) << ReadTextFile(dir / "unmapped.log");
  // Options no version renamed pass as they are.
  EXPECT_NE(record.find("--ImageReader.mask_path masks"), std::string::npos);
  EXPECT_NE(record.find("--Mapper.ba_refine_extra_params 0"),
            std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(SevenVersions, ColmapVersionsTest,
                         ::testing::Values("3.8", "3.9", "3.11", "3.12", "3.13",
                                           "4.0", "4.1"),
                         [](const auto& info) {
                           std::string name = "v" + info.param;
                           for (char& c : name)
                             if (c == '.') c = '_';
                           return name;
                         });

TEST(ColmapOptionsTest, ParsesTheVersionOfEveryFixture) {
  const std::map<std::string, std::string> expected = {
      {"3.8", "3.8"},     {"3.9", "3.9.1"},   {"3.11", "3.11.1"},
      {"3.12", "3.12.6"}, {"3.13", "3.13.0"}, {"4.0", "4.0.4"},
      {"4.1", "4.1.1"}};
  for (const auto& [dir, text] : expected) {
    const auto v =
        ParseColmapVersion(ReadTextFile(kFixtures / dir / "help.txt"));
    ASSERT_TRUE(v.has_value()) << dir;
    EXPECT_EQ(v->text, text) << dir;
    EXPECT_TRUE(CheckColmapVersion(*v)) << dir;
    // The command help carries the version too (after glog's prefix).
    const auto from_command = ParseColmapVersion(
        ReadTextFile(kFixtures / dir / "feature_extractor.txt"));
    ASSERT_TRUE(from_command.has_value()) << dir;
    EXPECT_EQ(from_command->text, text) << dir;
  }
}

TEST(ColmapOptionsTest, ParsesOptionsIncludingGlogPrefixedOutput) {
  const std::set<std::string> options = ParseColmapOptions(
      ReadTextFile(kFixtures / "4.1" / "feature_extractor.txt"));
  EXPECT_TRUE(options.count("FeatureExtraction.use_gpu"));
  EXPECT_TRUE(options.count("ImageReader.mask_path"));
  EXPECT_FALSE(options.count("SiftExtraction.use_gpu"));
  EXPECT_FALSE(options.count("help"));  // "-h [ --help ]" is not an option line
}

TEST(ColmapOptionsTest, AnOptionTheVersionLacksIsAnErrorNamingBoth) {
  testing::TempDir dir;
  // "4.2": 4.1's help without --ImageReader.mask_path.
  const fs::path fixtures = dir / "4.2";
  fs::create_directories(fixtures);
  for (const auto& e : fs::directory_iterator(kFixtures / "4.1")) {
    std::string text = ReadTextFile(e.path());
    std::string kept;
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);) {
      if (line.find("--ImageReader.mask_path") != std::string::npos) continue;
      kept += line + "\n";
    }
    for (std::size_t at; (at = kept.find("4.1.1")) != std::string::npos;)
      kept.replace(at, 5, "4.2.0");
    WriteFileAtomically(fixtures / e.path().filename(), kept);
  }
  const ColmapRunner colmap(FakeColmap(dir.path(), fixtures, true));
  FeatureExtractorSettings s;
  s.database = "db.db";
  s.images = "images";
  s.camera_model = "PINHOLE";
  s.masks = "masks";
  try {
    colmap.Run("feature_extractor", FeatureExtractorArgs(s),
               dir / "logs" / "feature_extractor.log");
    FAIL() << "ran without an option the version lacks";
  } catch (const Error& e) {
    const std::string what = e.what();
    for (const char* part : {"colmap 4.2.0", "feature_extractor",
                             "--ImageReader.mask_path", kTestedColmapVersions})
      EXPECT_NE(what.find(part), std::string::npos) << part << ": " << what;
  }
  EXPECT_FALSE(fs::exists(dir / "record.txt")) << "colmap ran regardless";
  // The newer version still runs what it has: the rename table holds.
  s.masks.clear();
  colmap.Run("feature_extractor", FeatureExtractorArgs(s),
             dir / "logs" / "feature_extractor.log");
  EXPECT_NE(
      ReadTextFile(dir / "record.txt").find("--FeatureExtraction.use_gpu"),
      std::string::npos);
}

TEST(ColmapOptionsTest, AVersionOlderThanSupportedIsRefused) {
  testing::TempDir dir;
  const fs::path fixtures = dir / "3.7";
  fs::create_directories(fixtures);
  WriteFileAtomically(fixtures / "help.txt",
                      "COLMAP 3.7 -- Structure-from-Motion and Multi-View "
                      "Stereo\n");
  const ColmapRunner colmap(FakeColmap(dir.path(), fixtures, false));
  try {
    colmap.Version(dir / "logs");
    FAIL() << "3.7 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("3.7"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("3.8"), std::string::npos) << e.what();
  }
}

TEST(ColmapOptionsTest, HelpWithoutAVersionIsAnError) {
  testing::TempDir dir;
  const fs::path fixtures = dir / "none";
  fs::create_directories(fixtures);
  WriteFileAtomically(fixtures / "help.txt", "usage: something else\n");
  const ColmapRunner colmap(FakeColmap(dir.path(), fixtures, false));
  EXPECT_THROW(colmap.Version(dir / "logs"), Error);
}

}  // namespace
}  // namespace pano4d
