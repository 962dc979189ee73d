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

// The whole command line: every command, the global options into
// `global`, the chosen command's function into `action`.
void BuildApp(CLI::App& app, GlobalOptions* global, Action* action) {
  app.set_version_flag("--version", std::string("pano4d ") + kVersion);
  app.require_subcommand(0, 1);
  app.footer(
      "Exit status: 0 ok, 1 error (the message names the input), 64 usage "
      "error, 75 stopped on request (SIGUSR1) with its state saved: run it "
      "again (fit: with --resume).");
  AddGlobalOptions(app, global);
  AddCommands(app, action);
  RefuseNonFiniteAndEmptyValues(&app);
}

constexpr const char* kAppDescription =
    "pano4d: monocular video to a dynamic 4D Gaussian scene, with unseen "
    "regions synthesised by panoramic expansion. Extra stages for a COLMAP "
    "workflow.";

}  // namespace

int CallCommand(const std::vector<std::string>& args) {
  CLI::App app{kAppDescription, "pano4d"};
  GlobalOptions global;
  Action action;
  BuildApp(app, &global, &action);
  std::vector<std::string> reversed(args.rbegin(), args.rend());
  try {
    app.parse(reversed);             // CLI11 takes the arguments last first
  } catch (const CLI::Success& e) {  // --help, --help-all, --version
    app.exit(e);
    return kExitOk;
  } catch (const CLI::ParseError& e) {
    throw Error::In("pano4d " + (args.empty() ? std::string() : args.front()),
                    e.what());
  }
  if (!action) {
    throw Error::In("pano4d", "no command given (see pano4d --help)");
  }
  std::vector<std::string> line{"pano4d"};
  line.insert(line.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : line) argv.push_back(a.data());
  SetThisCommandLine(static_cast<int>(argv.size()), argv.data());
  ApplyGlobalOptions(global);
  return action();
}

std::string CommandHelp(const std::string& command) {
  CLI::App app{kAppDescription, "pano4d"};
  GlobalOptions global;
  Action action;
  BuildApp(app, &global, &action);
  if (command.empty()) return app.help();
  CLI::App* sub = app.get_subcommand(command);  // throws for an unknown one
  return sub->help("pano4d");  // "Usage: pano4d fit", as the binary says
}

int Main(int argc, char** argv) {
  CLI::App app{kAppDescription, "pano4d"};
  GlobalOptions global;
  Action action;
  BuildApp(app, &global, &action);

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
