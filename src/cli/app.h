#pragma once

#include <functional>
#include <string>
#include <vector>

#include "src/core/stop_signal.h"

namespace CLI {
class App;
}

namespace pano4d::cli {

// Exit statuses of the pano4d binary.
enum ExitCode : int {
  kExitOk = 0,
  kExitError = 1,   // bad input, a failed step: the message names the input
  kExitUsage = 64,  // unknown flag, missing argument (sysexits' EX_USAGE)
  kExitBug = 70,    // a failed PANO4D_CHECK (core/check.h; EX_SOFTWARE)
  // Stopped on request (stop_signal.h) with its state saved: run the same
  // command again (sysexits' EX_TEMPFAIL).
  kExitStopped = kStoppedExitStatus,
};

// Parses argv, runs the chosen subcommand, and turns errors into one line on
// stderr ("pano4d: error: <input>: <problem>") and an exit status.
int Main(int argc, char** argv);

// A command run in-process as Main runs it (`args` as after `pano4d`: the
// command, its flags and the global ones), for what embeds pano4d (the
// Python module): the same parsing, checks and messages, but errors are
// thrown (pano4d::Error; a usage error is one naming the command), not
// printed. Returns the command's exit status: kExitOk, or kExitStopped
// when it stopped on request with its state saved. The global options
// (--threads, --quiet) stay set for the process, as in the binary.
int CallCommand(const std::vector<std::string>& args);
// `pano4d <command> --help`'s text (`pano4d --help`'s for ""). Throws
// CLI::OptionNotFound for an unknown command.
std::string CommandHelp(const std::string& command);

// A subcommand's parsed options live in its callback; the callback stores
// the function to run here, and Main runs it after parsing succeeds.
using Action = std::function<int()>;

void AddInspectCommand(CLI::App& app, Action* action);
void AddBenchCommand(CLI::App& app, Action* action);
void AddBenchStability(CLI::App* bench, Action* action);
void AddBenchBudget(CLI::App* bench, Action* action);
void AddBenchDatasets(CLI::App* bench, Action* action);
void AddDatasetCommand(CLI::App& app, Action* action);
void AddSynthCommand(CLI::App& app, Action* action);
void AddEvalCommand(CLI::App& app, Action* action);
void AddPlotCommand(CLI::App& app, Action* action);
void AddSfmCommand(CLI::App& app, Action* action);
void AddDepthCommand(CLI::App& app, Action* action);
void AddFitCommand(CLI::App& app, Action* action);
void AddExpandCommand(CLI::App& app, Action* action);
void AddMakePairsCommand(CLI::App& app, Action* action);
void AddRunCommand(CLI::App& app, Action* action);
void AddDemoCommand(CLI::App& app, Action* action);
void AddRenderCommand(CLI::App& app, Action* action);
void AddExportCommand(CLI::App& app, Action* action);
void AddViewCommand(CLI::App& app, Action* action);
void AddSweepCommand(CLI::App& app, Action* action);

}  // namespace pano4d::cli
