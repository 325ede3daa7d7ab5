// omni_fit: offline identification, simulation and diagnosis for the α-invariant model.
// Subcommands: fit (fit_command.cpp), simulate (simulate_command.cpp), diagnose
// (diagnose_command.cpp), sweep (sweep_command.cpp) and demo (demo_command.cpp); this file adds
// them and dispatches (fit's options are still declared here).
#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "apps/common/exit_code.hpp"
#include "demo_command.hpp"
#include "diagnose_command.hpp"
#include "fit_command.hpp"
#include "simulate_command.hpp"
#include "sweep_command.hpp"
#include "validate_command.hpp"

int main(int argc, char** argv) {
  CLI::App app{"omni_fit: identify and simulate alpha-invariant joint models"};
  app.require_subcommand(1);
  omni_fit::DemoCommandOptions demo_options;
  CLI::App* demo = omni_fit::add_demo_subcommand(app, demo_options);
  auto* fitc = app.add_subcommand("fit", "identify the linear, inertia and alpha-invariant models of a dataset");
  omni_fit::FitCommandOptions fo;
  fitc->add_option("dataset", fo.dataset_dirs,
                   "dataset folder(s) (alphainv-dataset/1), fitted together")->required();
  fitc->add_option("-o,--out", fo.out_dir, "output folder for model.json and report.md")->required();
  fitc->add_flag("--json", fo.json, "print one JSON object with the headline figures to stdout");
  fitc->add_flag("-q,--quiet", fo.quiet, "print nothing but errors");
  fitc->add_flag("--no-plots", fo.no_plots, "skip the report's figures (gnuplot)");
  fitc->add_option("--threads", fo.threads, "threads for the validation runs (default: all cores)");
  fitc->add_option("--breakpoints", fo.n_breakpoints, "number of alpha breakpoints N (2..8)")
      ->capture_default_str()->check(CLI::Range(2, 8));
  fitc->add_option("--disturbance-passes", fo.disturbance_passes,
                   "sine runs with a known disturbance_v: passes that simulate the model's "
                   "response to it, take it out of the run and refit the sine points, until they "
                   "move < 0.1 % (0: off)")
      ->capture_default_str()->check(CLI::Range(0, 100));
  fitc->add_option("--effects-from", fo.effects_from,
                   "fit with the known effects of this model.json (its \"effects\", e.g. from "
                   "`omni_fit diagnose`): the sine points are corrected for them, the simulations "
                   "include them, the written model carries them");
  fitc->add_option("--effect", fo.effect_specs,
                   "a known effect NAME:PARAM=VALUE[,PARAM=VALUE], repeatable, after "
                   "--effects-from; e.g. coulomb_friction:coulomb_v=0.004 (names: " +
                       alphainv::effect_names_text() + "; parameters as in model.json)")
      ->allow_extra_args(false);
  fitc->add_flag("--refine-effects", fo.refine_effects,
                 "refine the known effects' parameters on all runs: each trial a whole fit, "
                 "scored by the alpha-model's squared position error over every simulated run "
                 "(Nelder-Mead, at most --refine-evaluations fits); gravity's phase and size "
                 "are first searched globally (a grid over theta0 and g); `--effect gravity` "
                 "without values leaves them to that search");
  fitc->add_option("--refine-evaluations", fo.refine_evaluations,
                   "whole fits --refine-effects may spend (each costs one fit)")
      ->capture_default_str()->check(CLI::Range(1, 1000));
  fitc->add_option("--validate-on", fo.validate_on,
                   "validate the model on this dataset's runs (not fitted on), as `omni_fit "
                   "validate` does: figures in report.md and --json \"validation\"; repeatable")
      ->allow_extra_args(false);
  fitc->add_option("--holdout", fo.holdout,
                   "hold every K-th run of each pose out of the fit and validate on them")
      ->type_name("K")->check(CLI::Range(2, 1000000));
  fitc->add_option("--plot-runs", fo.plot_runs,
                   "held-out runs shown in the compare and resid figures (all when at most N, "
                   "else the N with the lowest fit %)")
      ->capture_default_str()->check(CLI::Range(0, 100000));
  fitc->footer("Examples:\n  omni_fit fit data/omni_yaw_sim -o out/fit --json\n"
               "  omni_fit fit data/omni_yaw_sim -o out/fit-ho --holdout 3\n"
               "  omni_fit fit part1/ part2/ -o out/fit12 --validate-on part3/\n"
               "  omni_fit fit data/omni_yaw_sim -o out/fit-fx --effect coulomb_friction:coulomb_v=0.004\n"
               "  omni_fit fit run_dir -o out/fit-fx --effects-from out/diag/model.json\n"
               "  omni_fit fit run_dir -o out/fit-fx --effects-from out/diag/model.json --refine-effects\n"
               "Exit codes: 0 ok, 1 usage, 2 bad input (the message names the file or option), 3 "
               "nothing could be fitted.");
  omni_fit::SimulateCommandOptions so;
  CLI::App* simc = omni_fit::add_simulate_subcommand(app, so);
  omni_fit::DiagnoseCommandOptions dgo;
  CLI::App* diagc = omni_fit::add_diagnose_subcommand(app, dgo);
  omni_fit::SweepCommandOptions swo;
  CLI::App* sweepc = omni_fit::add_sweep_subcommand(app, swo);
  omni_fit::ValidateCommandOptions vao;
  CLI::App* valc = omni_fit::add_validate_subcommand(app, vao);
  app.footer("Examples:\n  omni_fit fit data/omni_yaw_sim -o out/fit --json\n"
             "  omni_fit fit data/omni_yaw_sim -o out/fit-fx --effect coulomb_friction:coulomb_v=0.004\n"
             "  omni_fit fit data/omni_yaw_sim -o out/fit-fx --effects-from out/diag/model.json\n"
             "  omni_fit simulate out/fit/model.json --pose 60.08,87 --sine 3Hz -o run.csv\n"
             "  omni_fit diagnose data/omni_yaw_sim -o out/diag --json\n"
             "  omni_fit demo --gamma1 60.08 --gamma2 87 --amplitude 0.07\n"
             "Exit codes: 0 ok, 1 usage, 2 bad input (the message names the file), 3 nothing could be fitted\n"
             "(fit) or the simulation failed (simulate).");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return alphainv::apps::exit_status(code == 0 ? alphainv::apps::ExitCode::kOk
                                                 : alphainv::apps::ExitCode::kUsage);
  }
  int code = alphainv::apps::exit_status(alphainv::apps::ExitCode::kOk);
  if (*demo) code = omni_fit::run_demo(demo_options);
  if (*fitc) code = omni_fit::run_fit(fo);
  if (*simc) code = omni_fit::run_simulate(so);
  if (*diagc) code = omni_fit::run_diagnose(dgo);
  if (*sweepc) code = omni_fit::run_sweep(swo);
  if (*valc) code = omni_fit::run_validate(vao);
  // What a command printed must have arrived (`> /dev/full`, a closed pipe): else not exit 0.
  errno = 0;
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    std::fprintf(stderr, "omni_fit: cannot write to standard output%s%s\n", errno ? ": " : "",
                 errno ? std::strerror(errno) : "");
    if (code == 0) code = alphainv::apps::exit_status(alphainv::apps::ExitCode::kBadInput);
  }
  return code;
}
