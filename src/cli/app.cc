#include "src/cli/app.h"
#include "src/cli/options.h"

#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include <omp.h>
#include <CLI/CLI.hpp>

#include "src/core/check.h"
#include "src/core/error.h"
#include "src/core/log.h"
#include "src/core/stop_signal.h"
#include "src/core/version.h"
#include "src/core/workspace_lock.h"

namespace pano4d::cli {
namespace {

// The options every command takes, before or after its name.
struct GlobalOptions {
  std::string log_level = "info";
  bool verbose = false;
  bool quiet = false;
  int threads = 0;
};

void AddGlobalOptions(CLI::App& app, GlobalOptions* g) {
  app.add_option("--log-level", g->log_level, "debug, info, warning or error")
      ->check(CLI::IsMember({"debug", "info", "warning", "warn", "error"}))
      ->capture_default_str();
  app.add_flag("-v,--verbose", g->verbose, "Same as --log-level debug");
  app.add_flag("-q,--quiet", g->quiet, "Same as --log-level warning");
  app.add_option("--threads", g->threads,
                 "Threads for pano4d's parallel loops; 0: one per core. On "
                 "a machine shared with other work, fewer leave it cores "
                 "(waiting threads sleep rather than spin)")
      ->check(NonNegative())
      ->capture_default_str();
  // Global options may follow the subcommand: `pano4d fit -q --threads 1`.
  app.fallthrough();
}

void AddCommands(CLI::App& app, Action* action) {
  AddInspectCommand(app, action);
  AddBenchCommand(app, action);
  AddDatasetCommand(app, action);
  AddSynthCommand(app, action);
  AddEvalCommand(app, action);
  AddPlotCommand(app, action);
  AddSfmCommand(app, action);
  AddDepthCommand(app, action);
  AddFitCommand(app, action);
  AddExpandCommand(app, action);
  AddMakePairsCommand(app, action);
  AddRunCommand(app, action);
  AddDemoCommand(app, action);
  AddRenderCommand(app, action);
  AddExportCommand(app, action);
  AddViewCommand(app, action);
  AddSweepCommand(app, action);
}

void ApplyGlobalOptions(const GlobalOptions& g) {
  SetLogLevel(g.verbose ? LogLevel::kDebug
              : g.quiet ? LogLevel::kWarning
                        : ParseLogLevel(g.log_level).value_or(LogLevel::kInfo));
  if (g.threads <= 0) return;
  omp_set_num_threads(g.threads);
  const int cores = omp_get_num_procs();
  if (g.threads > cores) {
    PANO4D_LOG(kWarning)
        << "--threads " << g.threads << " is more than this machine's " << cores
        << " cores: every parallel loop then waits for threads "
        << "that share a core, which is slower, not faster; use at most "
        << cores;
  }
}

// Runs the command, its errors said on stderr with the exit status they
// call for.
int RunAction(const Action& action) {
  try {
    return action();
  } catch (const Error& e) {
    std::cerr << "pano4d: error: " << e.what() << "\n";
  } catch (const InternalError& e) {
    std::cerr << "pano4d: internal error: " << e.what() << "\n";
    return kExitBug;
  } catch (const std::exception& e) {
    std::cerr << "pano4d: error: " << e.what() << "\n";
  }
  return StopRequested() ? kExitStopped : kExitError;
}

}  // namespace

int Main(int argc, char** argv) {
  CLI::App app{
      "pano4d: monocular video to a dynamic 4D Gaussian scene, with unseen "
      "regions "
      "synthesised by panoramic expansion. Extra stages for a COLMAP workflow.",
      "pano4d"};
  app.set_version_flag("--version", std::string("pano4d ") + kVersion);
  app.require_subcommand(0, 1);
  app.footer(
      "Exit status: 0 ok, 1 error (the message names the input), 64 usage "
      "error, 75 stopped on request (SIGUSR1) with its state saved: run it "
      "again (fit: with --resume).");
  GlobalOptions global;
  AddGlobalOptions(app, &global);
  Action action;
  AddCommands(app, &action);
  RefuseNonFiniteAndEmptyValues(&app);

  SetThisCommandLine(argc, argv);  // a workspace lock names its holder
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kExitUsage;
  }
  ApplyGlobalOptions(global);
  if (!action) {
    std::cout << app.help();
    return kExitUsage;
  }
  return RunAction(action);
}

}  // namespace pano4d::cli
