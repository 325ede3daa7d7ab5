#include "simulate_command.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>

#include "alphainv/data/dataset.hpp"
#include "alphainv/error.hpp"
#include "alphainv/data/model_file.hpp"
#include "alphainv/simulate/model_simulation.hpp"
#include "apps/common/units.hpp"
#include "common/format.hpp"
#include "common/output_folder.hpp"

namespace omni_fit {

namespace {

using namespace alphainv;
namespace fs = std::filesystem;

int usage(const std::string& message) {
  std::fprintf(stderr, "omni_fit simulate: %s\nRun with --help for more information.\n",
               message.c_str());
  return 1;
}

/// "--sine: expected …" from an Error whose field is the option name.
std::string option_error(const Error& e) { return e.field() + ": " + e.message(); }

}  // namespace

CLI::App* add_simulate_subcommand(CLI::App& app, SimulateCommandOptions& so) {
  CLI::App* simc = app.add_subcommand(
      "simulate", "simulate a run with the model in model.json (writes the interchange format)");
  simc->add_option("model", so.model_path, "model.json (alphainv-model/1)")->required();
  simc->add_option("--pose", so.pose,
                   "pose gamma1,gamma2 [deg], e.g. 60.08,87 (needed with an inertia model)");
  simc->add_option("--sine", so.sine, "sine reference at this frequency, e.g. 3Hz");
  simc->add_option("--square", so.square, "square-wave reference at this frequency, e.g. 0.25Hz");
  simc->add_option("--amplitude", so.amplitude_rad, "reference amplitude [position unit]")
      ->capture_default_str();
  simc->add_option("--duration", so.duration, "run length, e.g. 8s or 500ms")
      ->capture_default_str();
  simc->add_option("--rate", so.rate, "output sample rate, e.g. 1kHz or 500Hz")
      ->capture_default_str();
  simc->add_option_function<double>(
      "--kp", [&so](const double& kp) { so.kp = kp; },
      "proportional gain [command unit/position unit] (default: the model's)");
  simc->add_flag("--linear", so.linear,
                 "the global linear model instead of the alpha-invariant model");
  simc->add_option("--disturbance", so.disturbance,
                   "a run CSV (t, r, theta, v and a disturbance_v and/or torque_enable column, "
                   "e.g. a recorded run) whose known inputs enter the plant, held between its "
                   "samples; the simulated run records them");
  simc->add_option("-o,--out", so.out,
                   "run CSV (written atomically), or a folder (ends with / or exists) for a whole "
                   "dataset; default: the CSV on stdout");
  simc->add_flag("-q,--quiet", so.quiet, "no summary on stderr");
  simc->footer(
      "Examples:\n"
      "  omni_fit simulate model.json --pose 60.08,87 --sine 3Hz -o run.csv\n"
      "  omni_fit simulate model.json --pose 60.08,87 --square 0.25Hz --duration 4s --linear -o "
      "ds/\n"
      "  omni_fit simulate model.json --pose 60.08,87 --sine 2.5Hz --duration 500ms > run.csv\n"
      "Columns: t, r, theta (simulated), v, alpha, C, beta_tilde, theta_dot.\n"
      "Exit codes: 0 ok, 1 usage, 2 bad model file (the message names the file and key) or\n"
      "unwritable output, 3 the simulation failed.");
  return simc;
}

int run_simulate(const SimulateCommandOptions& o) {
  // --- the command line -------------------------------------------------------------------------
  if (o.sine.empty() == o.square.empty())
    return usage("give exactly one of --sine FREQ and --square FREQ");
  ModelRunOptions run_opt;
  std::optional<std::pair<double, double>> pose;
  try {
    run_opt.reference = o.sine.empty() ? ModelRunReference::kSquare : ModelRunReference::kSine;
    run_opt.freq_hz = o.sine.empty() ? apps::parse_frequency_hz(o.square, "--square")
                                     : apps::parse_frequency_hz(o.sine, "--sine");
    run_opt.duration_s = apps::parse_duration_s(o.duration, "--duration");
    run_opt.sample_rate_hz = apps::parse_frequency_hz(o.rate, "--rate");
    if (!o.pose.empty()) pose = apps::parse_pose_deg(o.pose, "--pose");
  } catch (const Error& e) {
    return usage(option_error(e));
  }
  if (!(o.amplitude_rad > 0.0)) return usage("--amplitude: expected a number > 0");
  if (o.kp && !(*o.kp > 0.0)) return usage("--kp: expected a number > 0");
  run_opt.amplitude_rad = o.amplitude_rad;
  run_opt.kp = o.kp;
  RunData known_inputs;
  if (!o.disturbance.empty()) {
    try {
      known_inputs = read_run_csv(o.disturbance);
    } catch (const Error& e) {
      std::fprintf(stderr, "omni_fit simulate: --disturbance: %s\n", e.what());
      return 2;
    }
    if (known_inputs.column("disturbance_v") == nullptr &&
        known_inputs.column("torque_enable") == nullptr) {
      std::fprintf(stderr,
                   "omni_fit simulate: --disturbance: %s has neither a disturbance_v nor a "
                   "torque_enable column\n",
                   o.disturbance.c_str());
      return 2;
    }
    run_opt.known_inputs = &known_inputs;
  }

  // --- the model --------------------------------------------------------------------------------
  ModelFile model;
  try {
    model = read_model_file(o.model_path);
  } catch (const Error& e) {
    std::fprintf(stderr, "omni_fit simulate: %s\n", e.what());
    return 2;
  }
  if (!pose && model.has_inertia_model) {
    return usage("--pose G1,G2 is needed: " + o.model_path + " has an inertia model");
  }
  if (!pose && !model.has_inertia_model && model.poses.size() > 1) {
    return usage("--pose G1,G2 is needed: " + o.model_path + " has " +
                 std::to_string(model.poses.size()) + " per-pose linear models");
  }
  JointModelAtPose joint;
  std::string note;
  try {
    joint = model_at(model, pose ? std::optional<double>(pose->first) : std::nullopt,
                     pose ? std::optional<double>(pose->second) : std::nullopt, !o.linear, &note);
  } catch (const Error& e) {
    // What the model lacks at this pose: name the file and the key.
    std::fprintf(stderr, "omni_fit simulate: %s\n",
                 Error(e.message(), o.model_path, 0, e.field()).what());
    return 2;
  }

  // --- the run ----------------------------------------------------------------------------------
  ModelRun run;
  try {
    run = simulate_model_run(model, joint, run_opt,
                             pose ? std::optional<double>(pose->first) : std::nullopt,
                             pose ? std::optional<double>(pose->second) : std::nullopt);
  } catch (const Error& e) {
    return usage(e.what());
  }
  if (!run.ok) {
    std::fprintf(stderr, "omni_fit simulate: the simulation failed: %s\n", run.message.c_str());
    return 3;
  }

  // --- the output -------------------------------------------------------------------------------
  std::string wrote = "stdout";
  try {
    if (o.out.empty()) {
      const std::string text = format_run_csv(run.data, "stdout");
      const bool written = std::fwrite(text.data(), 1, text.size(), stdout) == text.size();
      if (!written || std::fflush(stdout) != 0 || std::ferror(stdout)) {
        throw Error(std::string("write failed: ") + std::strerror(errno), "stdout");
      }
    } else {
      const bool as_dataset = o.out.back() == '/' || fs::is_directory(o.out);
      if (as_dataset) {
        const Dataset ds = model_run_dataset(model, run, run_opt.sample_rate_hz);
        // Written whole beside the folder, then swapped into place (common/output_folder.hpp).
        const std::string top = fs::path(run.info.file).begin()->string();
        common::OutputFolder folder(o.out, {"dataset.json", top.c_str()});
        write_dataset(folder.path(), ds, {run.data});
        folder.commit();
        wrote = (fs::path(o.out) / "dataset.json").string() + " + " +
                (fs::path(o.out) / run.info.file).string();
      } else {
        write_run_csv(o.out, run.data);
        wrote = o.out;
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "omni_fit simulate: writing %s: %s\n",
                 o.out.empty() ? "stdout" : o.out.c_str(), e.what());
    return 2;
  }
  if (!o.quiet) {
    std::fprintf(
        stderr,
        "omni_fit simulate: %s\n  %s %g Hz, amplitude %g, %g s at %g Hz (%zu samples), kp %g, "
        "%s; wrote %s\n",
        note.c_str(), run.info.kind.c_str(), run_opt.freq_hz, run_opt.amplitude_rad,
        run_opt.duration_s, run_opt.sample_rate_hz, run.data.size(), run.controller.kp,
        model.loop_period_s > 0.0
            ? ("digital loop at " + common::num(1.0 / model.loop_period_s) + " Hz").c_str()
            : "continuous control law (43)",
        wrote.c_str());
    if (!active_effects(model.effects).empty()) {
      std::string names;
      for (EffectKind k : active_effects(model.effects)) {
        names += std::string(names.empty() ? "" : ", ") + effect_name(k);
      }
      std::fprintf(stderr, "  effects: %s\n", names.c_str());
    }
  }
  return 0;
}

}  // namespace omni_fit
