// omni_gen: generates datasets (alphainv-dataset/1) from the virtual Omni.
//   omni_gen paper -o DIR [--seed N] [--effect NAME:PARAM=VALUE ...] [--noise-std RAD]
//                         [--quantisation RAD] [--no-coulomb] [--truth-columns]
// A thin layer over alphainv::make_experiment_plan / generate_dataset / write_dataset.
// Every error prints one line on stderr naming the option; exit codes as the other apps
// (apps/common/exit_code.hpp): 1 a bad command line, 2 a rejected value or an unwritable output.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/error.hpp"
#include "alphainv/simulate/experiment_plan.hpp"
#include "apps/common/exit_code.hpp"

namespace {

namespace fs = std::filesystem;
using namespace alphainv;

/// Maps a validation field back to the command-line option that sets it.
std::string option_for_field(const std::string& field) {
  const std::string prefix = "plant.";
  const std::string f = field.rfind(prefix, 0) == 0 ? field.substr(prefix.size()) : field;
  for (const EffectSpec& spec : kEffectCatalogue) {
    for (const EffectParameter& p : spec) {
      if (f == std::string("effects.") + p.name) return "--effect " + std::string(spec.name);
    }
  }
  if (f == "measurement.noise_std_rad") return "--noise-std";
  if (f == "measurement.quantisation_rad") return "--quantisation";
  if (f == "seed") return "--seed";
  if (f.rfind("disturbance_pulses.", 0) == 0) return "--disturbance-pulses";
  return field;
}

int fail(const std::string& option, const std::string& message) {
  std::fprintf(stderr, "omni_gen: %s: %s\n", option.c_str(), message.c_str());
  return apps::exit_status(apps::ExitCode::kBadInput);
}

/// The command line, each argument quoted for a POSIX shell where needed.
std::string command_line(int argc, char** argv) {
  std::string out = "omni_gen";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool plain = !a.empty() && a.find_first_not_of(
                                         "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                         "0123456789-_=.,/:+") == std::string::npos;
    out += ' ';
    if (plain) {
      out += a;
    } else {
      out += '\'';
      for (char c : a) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
      out += '\'';
    }
  }
  return out;
}

struct PaperArgs {
  std::string out_dir;
  std::string seed = "1";
  std::vector<std::string> effects;
  double noise_std_rad = std::nan("");  // NaN: keep the bundled value
  double quantisation_rad = std::nan("");
  bool no_coulomb = false;
  bool truth_columns = false;
  bool unrecorded_disturbance = false;  // --disturbance-pulses act, their column is not written
  int pose = -1;  // -1: the paper's poses; K: only sine pose K (sine and square runs there)
  std::string disturbance_pulses;  // "AMPLITUDE_V[,WIDTH_S[,PERIOD_S]]"; empty: none
  std::string invented;            // an invented effect (invented_effects.hpp); empty: none
};

/// Parses --disturbance-pulses AMPLITUDE_V[,WIDTH_S[,PERIOD_S]] into `out`; returns an error text.
std::string parse_pulses(const std::string& text, DisturbancePulses& out) {
  double* fields[] = {&out.amplitude_v, &out.width_s, &out.period_s};
  std::size_t begin = 0;
  for (std::size_t i = 0; begin <= text.size(); ++i) {
    const std::size_t end = std::min(text.find(',', begin), text.size());
    if (i >= 3) return "expected at most 3 numbers, got '" + text + "'";
    const std::string cell = text.substr(begin, end - begin);
    char* stop = nullptr;
    const double x = std::strtod(cell.c_str(), &stop);
    if (cell.empty() || stop != cell.c_str() + cell.size() || !std::isfinite(x)) {
      return "expected AMPLITUDE_V[,WIDTH_S[,PERIOD_S]] (numbers), got '" + text + "'";
    }
    *fields[i] = x;
    begin = end + 1;
  }
  return {};
}

int run_paper(const PaperArgs& args, const std::string& cmd) {
  std::uint64_t seed = 0;
  const char* first = args.seed.data();
  const char* last = first + args.seed.size();
  const auto parsed = std::from_chars(first, last, seed);
  if (args.seed.empty() || parsed.ec != std::errc() || parsed.ptr != last) {
    return fail("--seed", "expected an integer in 0.." + std::to_string(UINT64_MAX) + ", got '" +
                              args.seed + "'");
  }
  ExperimentPlanOptions options = paper_plan_options(seed);
  options.generator_command = cmd;
  options.record_truth_columns = args.truth_columns;
  if (args.pose >= 0) {
    const auto poses = paper_sine_poses();
    if (static_cast<std::size_t>(args.pose) >= poses.size()) {
      return fail("--pose", "expected 0.." + std::to_string(poses.size() - 1) + ", got " +
                                std::to_string(args.pose));
    }
    options.sine_poses = {poses[static_cast<std::size_t>(args.pose)]};
    options.square_poses = options.sine_poses;
  }
  if (!args.invented.empty()) {
    try {
      options.invented = parse_invented_effect(args.invented, "--invented");
    } catch (const Error& e) {
      return fail("--invented", e.message());
    }
  }
  if (!args.disturbance_pulses.empty()) {
    const std::string why = parse_pulses(args.disturbance_pulses, options.disturbance_pulses);
    if (!why.empty()) return fail("--disturbance-pulses", why);
  }
  Effects& effects = options.plant.effects;
  if (args.no_coulomb) effects.coulomb_v = 0.0;
  if (!std::isnan(args.noise_std_rad)) options.plant.measurement.noise_std_rad = args.noise_std_rad;
  if (!std::isnan(args.quantisation_rad)) {
    options.plant.measurement.quantisation_rad = args.quantisation_rad;
  }
  for (const std::string& spec : args.effects) {
    const std::string option = "--effect " + spec;
    try {
      Effects one;
      apply_effect_spec(spec, one, option);
      const EffectKind kind = effect_kind_from_name(spec.substr(0, spec.find_first_of(":=")));
      if (effect_spec(kind).role == EffectRole::kTimeSeries) {
        return fail(option, "a torque of time, not a plant parameter: generate it with "
                            "--disturbance-pulses AMPLITUDE_V[,WIDTH_S[,PERIOD_S]] "
                            "--unrecorded-disturbance (the pulses act, their column is not written)");
      }
      if (kind == EffectKind::kCoulombFriction && args.no_coulomb) {
        return fail(option, "contradicts --no-coulomb");
      }
      for (const EffectParameter& p : effect_spec(kind)) effects.*(p.member) = one.*(p.member);
    } catch (const Error& e) {
      return fail(option, e.message());
    }
  }

  ExperimentPlan plan;
  try {
    plan = make_experiment_plan(options);
  } catch (const Error& e) {
    return fail(option_for_field(e.field()), e.message());
  }

  const auto t0 = std::chrono::steady_clock::now();
  GeneratedDataset data = generate_dataset(plan);
  if (args.unrecorded_disturbance) {
    // The pulses acted on the plant; the dataset does not know them (its truth does).
    for (RunData& run : data.runs) run.extra_columns.erase("disturbance_v");
  }
  const auto t1 = std::chrono::steady_clock::now();
  try {
    write_dataset(args.out_dir, data.index, data.runs);
  } catch (const Error& e) {
    return fail("-o " + args.out_dir, e.what());
  } catch (const std::exception& e) {
    return fail("-o " + args.out_dir, e.what());
  }
  const auto t2 = std::chrono::steady_clock::now();

  std::uintmax_t bytes = 0;
  std::size_t rows = 0;
  std::error_code ec;
  bytes += fs::file_size(fs::path(args.out_dir) / "dataset.json", ec);
  for (std::size_t i = 0; i < plan.runs.size(); ++i) {
    bytes += fs::file_size(fs::path(args.out_dir) / plan.runs[i].file, ec);
    rows += data.runs[i].size();
  }
  std::size_t sines = 0;
  for (const PlannedRun& r : plan.runs) sines += r.kind == "sine";
  std::printf(
      "omni_gen: wrote %s: %zu runs (%zu sine, %zu square), %zu rows, %.1f MB "
      "(%ju bytes); simulated in %.2f s, written in %.2f s\n",
      args.out_dir.c_str(), plan.runs.size(), sines, plan.runs.size() - sines, rows,
      static_cast<double>(bytes) / 1e6, bytes, std::chrono::duration<double>(t1 - t0).count(),
      std::chrono::duration<double>(t2 - t1).count());
  return apps::exit_status(apps::ExitCode::kOk);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "omni_gen: generate alphainv-dataset/1 datasets from the virtual Phantom Omni yaw joint"};
  app.require_subcommand(1);
  app.footer(
      "Example:\n"
      "  omni_gen paper -o data/omni_yaw_sim --seed 1\n"
      "  omni_gen paper -o /tmp/gravity --seed 5 --no-coulomb --effect gravity:gravity_v=0.02,gravity_theta0_rad=0.1 --noise-std 0");

  PaperArgs args;
  auto* paper = app.add_subcommand(
      "paper",
      "the paper's experiment plan: Table 1 (sine 1.5-7 Hz +-0.07 rad at 9 poses) and Table 2 "
      "(0.25 Hz +-0.07 rad square wave at 25 poses), kp = 2 P law at 1 kHz, with the bundled "
      "effects (Coulomb friction 0.004 V, encoder quantisation 1.5e-4 rad, noise 5e-5 rad)");
  paper
      ->add_option("-o,--out", args.out_dir,
                   "output dataset folder (created; its dataset.json is replaced)")
      ->required();
  paper
      ->add_option("--seed", args.seed,
                   "seed of the true poses and the measurement noise, 0..2^64-1")
      ->type_name("N")
      ->capture_default_str();
  std::string effect_help =
      "set a plant effect, NAME:PARAM=VALUE[,PARAM=VALUE] (model.json's names, as `omni_fit fit "
      "--effect` takes them) or NAME=VALUE for its first parameter; repeatable. Effects:";
  for (const EffectSpec& spec : kEffectCatalogue) {
    if (spec.kind == EffectKind::kNone) continue;
    effect_help += std::string("\n  ") + spec.name + ": " + spec.description;
    for (const EffectParameter& p : spec)
      effect_help += std::string("\n    ") + p.name + ": " + p.description + " [" + p.unit + "]";
  }
  paper->add_option("--effect", args.effects, effect_help)->take_all()->allow_extra_args(false);
  const CLI::Validator non_negative(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const double x = std::strtod(text.c_str(), &end);
        if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(x) || x < 0.0) {
          return "expected a finite number >= 0, got '" + text + "'";
        }
        return {};
      },
      "RAD>=0");
  paper
      ->add_option("--noise-std", args.noise_std_rad, "measurement noise std [rad] (bundled: 5e-5)")
      ->check(non_negative);
  paper
      ->add_option("--quantisation", args.quantisation_rad,
                   "encoder quantisation step [rad], 0 = none (bundled: 1.5e-4)")
      ->check(non_negative);
  paper
      ->add_option("--pose", args.pose,
                   "only pose K of the paper's 9 sine poses, sine and square runs there (10 runs: "
                   "what `omni_fit sweep` diagnoses; seed s uses pose s mod 9)")
      ->type_name("K");
  paper
      ->add_option("--disturbance-pulses", args.disturbance_pulses,
                   "known external disturbance pulses on every run, recorded as its "
                   "disturbance_v column: +-AMPLITUDE_V [command unit] (alternating), WIDTH_S "
                   "long (default 0.1), one every PERIOD_S (default 1) from 0.5 s plus a per-run "
                   "shift; e.g. 0.05 or 0.05,0.1,1")
      ->type_name("AMPLITUDE_V[,WIDTH_S[,PERIOD_S]]");
  paper->add_flag("--unrecorded-disturbance", args.unrecorded_disturbance,
                  "with --disturbance-pulses: the pulses act on the plant but their disturbance_v "
                  "column is not written (an external_disturbance the dataset does not know; "
                  "dataset.json's truth has them)");
  paper
      ->add_option("--invented", args.invented,
                   "an invented effect no model knows, on every run, not recorded (truth.json "
                   "says it; for trying diagnose in the open world): lugre (a dynamic friction "
                   "with a bristle state), drift (a friction level that drifts between runs) or "
                   "hysteresis (a frictional lag in velocity), with PARAM=VALUE of level_v, "
                   "breakaway_v, velocity_rad_s, stiffness_v_per_rad, lag_s, drift; e.g. "
                   "lugre:level_v=0.008")
      ->type_name("KIND[:PARAM=VALUE,...]");
  paper->add_flag("--no-coulomb", args.no_coulomb, "turn the bundled Coulomb friction off");
  paper->add_flag("--truth-columns", args.truth_columns,
                  "add the columns theta_true, theta_dot_true, v_eff, alpha_true, c_true, "
                  "beta_tilde_true to every run");
  paper->footer(
      "Example:\n  omni_gen paper -o data/omni_yaw_sim --seed 1\n"
      "  omni_gen paper -o /tmp/delay --seed 2 --effect time_delay=0.002 --effect deadzone=0.005");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr,
                 "omni_gen: %s\nRun 'omni_gen --help' or 'omni_gen paper --help' for usage.\n",
                 e.what());
    return apps::exit_status(apps::ExitCode::kUsage);
  }
  if (paper->parsed()) return run_paper(args, command_line(argc, argv));
  return apps::exit_status(apps::ExitCode::kUsage);
}
