// pano4d view: the fitted 4D scene in a browser (src/pipeline/view.h).
#include <cstdio>
#include <memory>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/static_server.h"
#include "src/pipeline/view.h"
#include "src/core/workspace_lock.h"

namespace pano4d::cli {
namespace fs = std::filesystem;

void AddViewCommand(CLI::App& app, Action* action) {
  struct Options {
    fs::path workspace;
    ViewOptions view;
    int serve = -1;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand(
      "view",
      "Write a web page that shows the fitted 4D scene (time slider, orbit "
      "and fly, cameras as frusta), and serve it with --serve");
  sub->add_option("--workspace", o->workspace,
                  "The workspace (frames.json and the fit checkpoint)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--out", o->view.out,
                  "Output folder (default WS/pano4d/view)");
  sub->add_option("--serve", o->serve,
                  "Serve the folder on http://127.0.0.1:PORT/ until Ctrl-C "
                  "(0: any free port)")
      ->check(InRange(0, 65535));
  sub->footer(
      "Writes OUT/index.html, OUT/viewer.js, OUT/lib/ (three.js and Spark, "
      "from npm, with their licences) and the compact 4D scene "
      "OUT/scene4d.json + OUT/scene4d.bin. Browsers load the page from a "
      "server, not from file://: use --serve, or any static server (`python3 "
      "-m http.server -d OUT`). Nothing is fetched from the network.");
  sub->callback([action, o] {
    *action = [o] {
      ViewSummary s;
      {  // the workspace is read while the page is written, not served
        const FolderLock lock =
            LockWorkspace(o->workspace, FolderLock::Mode::kShared);
        s = RunView(Workspace(o->workspace), o->view);
      }
      std::printf("%s", s.FullReport().c_str());
      if (o->serve >= 0) {
        StaticServer server(s.out, o->serve);
        std::printf("pano4d view: serving %s at %s (Ctrl-C stops)\n",
                    s.out.c_str(), server.url().c_str());
        std::fflush(stdout);
        server.Serve();
      }
      return kExitOk;
    };
  });
}

}  // namespace pano4d::cli
