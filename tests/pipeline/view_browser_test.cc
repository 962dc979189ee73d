// `pano4d view`'s page in a real browser: headless Chromium (software
// WebGL, SwiftShader) opens the page from a local server in capture mode
// (viewer.js: ?capture=FILE), which renders given cameras at given times
// and POSTs the PNGs back. They are compared with `pano4d render` of the
// same cameras, and between times where the scene moves.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "src/core/file.h"
#include "src/core/json.h"
#include "src/core/psnr.h"
#include "src/core/static_server.h"
#include "src/core/subprocess.h"
#include "tests/support/test_files.h"

extern char** environ;

namespace pano4d {
namespace {
namespace fs = std::filesystem;
using testing::RunPano4d;
using testing::Slurp;

// Each camera of the tiny scene (64 x 48) scaled up, so that the page
// draws a few hundred pixels across.
constexpr double kScale = 4.0;
// Spark in Chromium 156's SwiftShader against pano4d's rasterizer on this
// scene measured 46.1 to 46.6 dB (docs/experiments/
// 2026-12-03-web-viewer.md); the floor leaves room for other Chromium
// and SwiftShader builds, and stays far above a page that draws another
// time (the movers alone cost about 20 dB) or a blank one.
constexpr double kMinPsnr = 35.0;
// How long the page may take from launch to its last screenshot.
constexpr double kBrowserSeconds = 150.0;

std::optional<fs::path> FindChromium() {
  if (const char* env = std::getenv("PANO4D_CHROMIUM"); env && *env)
    return fs::path(env);
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"})
    if (auto found = FindOnPath(name)) return found;
  return std::nullopt;
}

Json Scaled(Json camera, double s) {
  for (const char* k : {"fx", "fy", "cx", "cy"})
    camera[k] = camera[k].get<double>() * s;
  for (const char* k : {"width", "height"})
    camera[k] = static_cast<int>(std::lround(camera[k].get<int>() * s));
  return camera;
}

double Psnr(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat d;
  cv::absdiff(a, b, d);
  d.convertTo(d, CV_64F, 1.0 / 255);
  const cv::Scalar mse = cv::mean(d.mul(d));
  return PsnrFromMse((mse[0] + mse[1] + mse[2]) / 3);
}

// Mean absolute difference (0..255) of two images inside `mask`.
double MeanDifference(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  cv::Mat d, gray;
  cv::absdiff(a, b, d);
  cv::cvtColor(d, gray, cv::COLOR_BGR2GRAY);
  return cv::mean(gray, mask)[0];
}

TEST(ViewBrowserTest, ThePageShowsTheSceneAndItsMotion) {
  const std::optional<fs::path> chromium = FindChromium();
  if (!chromium) {
    GTEST_SKIP() << "CHROMIUM MISSING: the browser test needs headless "
                    "Chromium; `bash scripts/setup.sh` installs it (apt-get "
                    "install chromium), or set PANO4D_CHROMIUM";
  }
  testing::TempDir dir;
  const fs::path ws = dir / "ws", view = dir / "view";
  ASSERT_EQ(RunPano4d("synth --preset tiny --seed 3 --out '" +
                          (dir / "tiny").string() + "'",
                      dir / "synth.log"),
            0)
      << Slurp(dir / "synth.log");
  ASSERT_EQ(RunPano4d("depth --workspace '" + ws.string() + "' --dataset '" +
                          (dir / "tiny").string() + "'",
                      dir / "depth.log"),
            0)
      << Slurp(dir / "depth.log");
  ASSERT_EQ(RunPano4d("fit --workspace '" + ws.string() +
                          "' --iterations 300 --deterministic",
                      dir / "fit.log"),
            0)
      << Slurp(dir / "fit.log");
  ASSERT_EQ(RunPano4d("view --workspace '" + ws.string() + "' --out '" +
                          view.string() + "'",
                      dir / "view.log"),
            0)
      << Slurp(dir / "view.log");

  // Two training cameras, each at the first and the last time.
  const Json header = ReadJson(view / "scene4d.json");
  const Json& training = header["extras"]["cameras"]["training"];
  ASSERT_GE(training.size(), 5u);
  const int last = header["num_times"].get<int>() - 1;
  ASSERT_GT(last, 0);
  Json shots = Json::array(), views = Json::array();
  for (const int c : {0, 4}) {
    for (const int t : {0, last}) {
      const Json camera = Scaled(training[c]["camera"], kScale);
      shots.push_back(
          {{"name", "cam" + std::to_string(c) + "_t" + std::to_string(t)},
           {"camera", camera},
           {"t", t}});
      views.push_back({{"camera", camera}, {"t", t}});
    }
  }
  WriteJson(view / "capture.json", shots);
  WriteJson(dir / "cameras.json", {{"views", views}});
  ASSERT_EQ(RunPano4d("render --workspace '" + ws.string() +
                          "' --trajectory '" + (dir / "cameras.json").string() +
                          "' --out '" + (dir / "reference").string() + "'",
                      dir / "render.log"),
            0)
      << Slurp(dir / "render.log");

  // The page's POSTs, by path.
  std::mutex mutex;
  std::map<std::string, std::string> posted;
  StaticServer server(view, 0,
                      [&](const std::string& path, const std::string& body) {
                        const std::lock_guard<std::mutex> lock(mutex);
                        posted[path] = body;
                        return true;
                      });
  server.ServeInBackground();
  const std::string url = server.url() + "index.html?capture=capture.json";
  const std::string profile = (dir / "chromium-profile").string();
  std::vector<std::string> args = {chromium->string(),
                                   "--headless=new",
                                   "--no-sandbox",
                                   "--no-first-run",
                                   "--disable-extensions",
                                   "--use-angle=swiftshader",
                                   "--enable-unsafe-swiftshader",
                                   "--window-size=800,600",
                                   "--user-data-dir=" + profile,
                                   url};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const fs::path browser_log = dir / "chromium.log";
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, browser_log.c_str(),
                                   O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attributes, 0);
  pid_t pid = -1;
  ASSERT_EQ(
      posix_spawn(&pid, argv[0], &actions, &attributes, argv.data(), environ),
      0);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  const auto start = std::chrono::steady_clock::now();
  bool finished = false;
  while (!finished) {
    {
      const std::lock_guard<std::mutex> lock(mutex);
      finished = posted.count("/capture/done.json") ||
                 posted.count("/capture/error.json");
    }
    const double waited =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
            .count();
    if (finished || waited > kBrowserSeconds) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  kill(-pid, SIGKILL);  // Chromium and its helpers
  waitpid(pid, nullptr, 0);
  server.Stop();
  ASSERT_FALSE(posted.count("/capture/error.json"))
      << posted["/capture/error.json"];
  ASSERT_TRUE(finished) << "no screenshots within " << kBrowserSeconds
                        << " s; Chromium's log: " << Slurp(browser_log);
  const Json stats = ParseJson(posted["/capture/done.json"], "done.json");
  std::printf("browser: %s, %.1f frames/s still, %.1f playing at %dx%d\n",
              stats["webgl"].get<std::string>().c_str(),
              stats["fps_still"].get<double>(),
              stats["fps_playing"].get<double>(), stats["width"].get<int>(),
              stats["height"].get<int>());

  // Each screenshot against pano4d's render of the same camera and time;
  // the screenshots are kept beside the log for a person to look at.
  std::map<std::string, cv::Mat> page, reference;
  for (std::size_t i = 0; i < shots.size(); ++i) {
    const std::string name = shots[i]["name"];
    const std::string& png = posted["/capture/" + name + ".png"];
    ASSERT_FALSE(png.empty()) << name;
    page[name] = cv::imdecode(cv::Mat(1, static_cast<int>(png.size()), CV_8U,
                                      const_cast<char*>(png.data())),
                              cv::IMREAD_COLOR);
    reference[name] = cv::imread(
        (dir / "reference" / (ZeroPadded(static_cast<int>(i), 5) + ".png"))
            .string(),
        cv::IMREAD_COLOR);
    ASSERT_FALSE(page[name].empty()) << name;
    ASSERT_EQ(page[name].size(), reference[name].size()) << name;
    const double psnr = Psnr(page[name], reference[name]);
    std::printf("%s: PSNR %.2f dB against pano4d render\n", name.c_str(), psnr);
    EXPECT_GT(psnr, kMinPsnr) << name;
    if (const char* keep = std::getenv("PANO4D_KEEP_SCREENSHOTS")) {
      cv::Mat pair;
      cv::hconcat(page[name], reference[name], pair);
      cv::imwrite((fs::path(keep) / (name + ".png")).string(), pair);
    }
  }
  // Where pano4d's renders change between the times (the movers), the
  // page's do too; elsewhere the page stays nearly still.
  for (const int c : {0, 4}) {
    const std::string a = "cam" + std::to_string(c) + "_t0";
    const std::string b =
        "cam" + std::to_string(c) + "_t" + std::to_string(last);
    cv::Mat d, gray, moving, still;
    cv::absdiff(reference[a], reference[b], d);
    cv::cvtColor(d, gray, cv::COLOR_BGR2GRAY);
    moving = gray > 40;
    still = gray < 5;
    ASSERT_GT(cv::countNonZero(moving), 100) << a << ": nothing moves";
    const double in_motion = MeanDifference(page[a], page[b], moving);
    const double at_rest = MeanDifference(page[a], page[b], still);
    std::printf(
        "camera %d: page changes %.1f where the scene moves, %.1f "
        "where it does not (of 255)\n",
        c, in_motion, at_rest);
    EXPECT_GT(in_motion, 20.0) << a;
    EXPECT_LT(at_rest, 0.5 * in_motion) << a;
  }
}

}  // namespace
}  // namespace pano4d
