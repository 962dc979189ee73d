// pano4d sweep: benchmark sweeps as job arrays (src/lab/sweep.h).
#include <cstdio>
#include <memory>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/lab/sweep.h"

namespace pano4d::cli {
namespace fs = std::filesystem;
namespace {

void AddPlan(CLI::App* sweep, Action* action) {
  auto plan = std::make_shared<SweepPlanOptions>();
  CLI::App* p = sweep->add_subcommand(
      "plan",
      "Write SWEEP/manifest.json: one entry per scene x seed x "
      "configuration, with its workspace and command");
  p->add_option("--root", plan->root, "A folder of benchmark scenes")
      ->required()
      ->check(CLI::ExistingDirectory);
  p->add_option("--suite", plan->suite,
                "nvidia, dycheck, kubric or synth (default: all)");
  p->add_option("--scenes", plan->scenes, "Only these scene folders")
      ->delimiter(',');
  p->add_option("--seeds", plan->seeds, "Seeds, e.g. 0,1,2")
      ->delimiter(',')
      ->capture_default_str();
  p->add_option("--configs", plan->configs,
                "default, no-expansion, planar, one-step, no-refinement, "
                "no-motion")
      ->delimiter(',')
      ->capture_default_str();
  p->add_option("--iterations", plan->iterations,
                "Fit iterations per entry (default: run's schedule)");
  p->add_flag("--deterministic", plan->deterministic,
              "Results that do not depend on threads or machine");
  p->add_option("--lpips-weights", plan->lpips_weights, "For LPIPS");
  p->add_option(
       "--priors", plan->priors,
       "A root of learned priors per scene: ROOT/<scene>/ in any layout "
       "--priors reads (the data root itself when each scene "
       "folder holds its own); scenes without are run without")
      ->check(CLI::ExistingDirectory);
  p->add_option("--out", plan->out, "The sweep folder (SWEEP)")->required();
  p->callback([action, plan] {
    *action = [plan] {
      const Json m = PlanSweep(*plan);
      std::printf("pano4d sweep plan: %zu entries in %s\n", m["entries"].size(),
                  (plan->out / "manifest.json").c_str());
      return kExitOk;
    };
  });
}

void AddRun(CLI::App* sweep, Action* action) {
  struct Run {
    fs::path sweep;
    int index = -1;
  };
  auto run = std::make_shared<Run>();
  CLI::App* r = sweep->add_subcommand(
      "run",
      "Run one entry (resumable); exit 75 when stopped on request, "
      "so that a batch script requeues it");
  r->add_option("sweep", run->sweep, "The sweep folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  r->add_option("--index", run->index,
                "The entry (default: $SLURM_ARRAY_TASK_ID, else "
                "$JOB_COMPLETION_INDEX)");
  r->callback([action, run] {
    *action = [run] {
      const Json m = ReadSweepManifest(run->sweep);
      const int index = SweepTaskIndex(run->index, m["entries"].size());
      switch (RunSweepEntry(run->sweep, index)) {
        case SweepOutcome::kDone:
        case SweepOutcome::kDoneEarlier:
          return kExitOk;
        case SweepOutcome::kStopped:
          return kExitStopped;
        case SweepOutcome::kFailed:
          break;
      }
      std::fprintf(
          stderr, "pano4d: error: sweep entry %d failed; see %s\n", index,
          (run->sweep / "status" / (std::to_string(index) + ".json")).c_str());
      return kExitError;
    };
  });
}

void AddSbatch(CLI::App* sweep, Action* action) {
  struct Sbatch {
    fs::path sweep;
    SbatchOptions options;
    bool submit = false;
  };
  auto sb = std::make_shared<Sbatch>();
  CLI::App* s = sweep->add_subcommand(
      "sbatch",
      "Write SWEEP/sweep.sbatch, a Slurm job array of the entries "
      "(--requeue, USR1 before the time limit); --submit submits "
      "it");
  s->add_option("sweep", sb->sweep, "The sweep folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  s->add_option("--partition", sb->options.partition, "Slurm partition");
  s->add_option("--cpus", sb->options.cpus, "CPUs per task")
      ->capture_default_str();
  s->add_option("--mem", sb->options.mem, "Memory per task, e.g. 8G");
  s->add_option("--time", sb->options.time, "Time limit, e.g. 02:00:00");
  s->add_option("--max-parallel", sb->options.max_parallel,
                "Tasks at once (0: no limit)");
  s->add_flag("--submit", sb->submit, "Submit with sbatch, print the job id");
  s->callback([action, sb] {
    *action = [sb] {
      const fs::path script = WriteSbatchScript(sb->sweep, sb->options);
      std::printf("pano4d sweep sbatch: %s\n", script.c_str());
      if (sb->submit)
        std::printf("submitted job %s\n", SubmitSbatch(script).c_str());
      return kExitOk;
    };
  });
}

void AddLocal(CLI::App* sweep, Action* action) {
  struct Local {
    fs::path sweep;
    int jobs = 1;
  };
  auto local = std::make_shared<Local>();
  CLI::App* l = sweep->add_subcommand(
      "local", "Run every entry on this machine, --jobs at a time");
  l->add_option("sweep", local->sweep, "The sweep folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  l->add_option("--jobs", local->jobs, "Entries at once")
      ->capture_default_str();
  l->callback([action, local] {
    *action = [local] {
      const int not_done = RunSweepLocal(local->sweep, local->jobs);
      std::printf(
          "pano4d sweep local: %d entries not done (sweep collect "
          "lists them)\n",
          not_done);
      if (StopRequested()) return kExitStopped;  // the entries saved theirs
      return not_done == 0 ? kExitOk : kExitError;
    };
  });
}

void AddCollect(CLI::App* sweep, Action* action) {
  auto collect = std::make_shared<fs::path>();
  CLI::App* c = sweep->add_subcommand(
      "collect", "Merge every entry's metrics into SWEEP/sweep.md and .csv");
  c->add_option("sweep", *collect, "The sweep folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  c->callback([action, collect] {
    *action = [collect] {
      const SweepTable t = CollectSweep(*collect);
      std::printf(
          "%s\npano4d sweep collect: %d entries, %d done, %d failed "
          "or stopped, %d missing; %s\n",
          t.markdown.c_str(), t.entries, t.done, t.failed, t.missing,
          (*collect / "sweep.md").c_str());
      return kExitOk;
    };
  });
}

}  // namespace

void AddSweepCommand(CLI::App& app, Action* action) {
  CLI::App* sweep = app.add_subcommand(
      "sweep",
      "Benchmark sweeps (scenes x seeds x configurations) as Slurm job "
      "arrays, Kubernetes Indexed Jobs or a local process pool");
  sweep->require_subcommand(1);
  AddPlan(sweep, action);
  AddRun(sweep, action);
  AddSbatch(sweep, action);
  AddLocal(sweep, action);
  AddCollect(sweep, action);
}

}  // namespace pano4d::cli
