// omni_ctl: the loop setup, a run's command and recording, from the options.
#include <unistd.h>

#include <cstdlib>

#include "alphainv/device/hid_transport.hpp"
#include "alphainv/device/sim_transport.hpp"
#include "alphainv/error.hpp"
#include "alphainv/data/model_file.hpp"
#include "alphainv/simulate/virtual_omni.hpp"
#include "options.hpp"

namespace omni_ctl {

using namespace alphainv;

namespace {

/// The loop configuration of `opt` (model file loaded, limits applied); `model_source` receives
/// "paper (Tables 5-7)" or the file, `model_note` what the file lacks and its effects.
rt::ControlLoopConfig make_loop_config(const Options& opt, std::string& model_source,
                                       std::string& model_note) {
  rt::ControlLoopConfig cfg;
  cfg.kp = opt.kp;
  cfg.safety = opt.safety;
  model_source = "paper (Tables 5-7)";
  if (!opt.model_path.empty()) {
    const ModelFile m = read_model_file(opt.model_path);  // throws naming the file and key
    model_source = opt.model_path;
    if (m.has_inertia_model) {
      cfg.inertia = m.linear.inertia;
    } else {
      // Without an inertia model the fit's alpha model is per pose, fitted with I = 1 (as
      // omni_fit simulate and validate use it): C = 1/C_n1, beta~ = 1/beta_n1 at any pose.
      cfg.inertia = InertiaModel{1.0, 0.0, 0.0, 0.0, 0.0};
      model_note += "model file has no inertia model: its per-pose model is used with I = 1. ";
    }
    if (m.has_alpha_model) {
      cfg.model = m.alpha;
    } else if (m.has_inertia_model) {
      cfg.model = constant_alpha_model(m.linear.c0_bar, 1.0);
      model_note += "model file has no alpha model: using its global linear model (24)-(26). ";
    } else {
      throw Error("expected an alpha model or an inertia model, found neither", opt.model_path, 0,
                  "alpha");
    }
    cfg.effects = m.effects;  // e.g. from omni_fit diagnose: the prediction honours them
    if (!active_effects(m.effects).empty()) {
      std::string names;
      for (EffectKind k : active_effects(m.effects)) names += std::string(" ") + effect_name(k);
      model_note += "model effects:" + names + ". ";
    }
    if (!cfg.model.valid()) {
      throw Error("the alpha model is not valid (breakpoints must increase, C_n1 > 0)",
                  opt.model_path, 0, "alpha");
    }
  }
  if (!opt.compensate.empty()) {
    cfg.compensation.mode = rt::compensation_mode_from_name(opt.compensate, "--compensate");
    if (rt::cancels_effects(cfg.compensation.mode) && active_effects(cfg.effects).empty()) {
      model_note += "--compensate " + opt.compensate + ": the model has no effects to cancel. ";
    }
  }
  if (opt.compensate_damping > 0.0) {
    if (cfg.compensation.mode != rt::CompensationMode::kEffects) {
      throw Error("--compensate-damping needs --compensate effects (the feedforward modes hold "
                  "the damping along the reference already)",
                  {}, 0, "--compensate-damping");
    }
    cfg.compensation.damping_fraction = opt.compensate_damping;
  }
  cfg.validate();
  return cfg;
}

/// The virtual Omni of `opt`: the paper's plant with the --sim-effect effects.
VirtualOmniParams sim_plant(const Options& opt) {
  VirtualOmniParams p;
  for (const std::string& spec : opt.sim_effects) {
    apply_effect_spec(spec, p.effects, "--sim-effect " + spec);
  }
  p.measurement.noise_std_rad = opt.sim_noise_rad;
  p.measurement.seed = opt.sim_seed;
  p.validate();  // names the field, e.g. a Coulomb level too stiff for the RK4 step
  return p;
}

std::unique_ptr<device::Transport> make_transport(const Options& opt) {
  if (opt.device == "sim") {
    device::SimFault fault;
    if (!opt.sim_fault.empty()) fault = device::parse_sim_fault(opt.sim_fault, "--sim-fault");
    auto sim = std::make_unique<device::SimTransport>(sim_plant(opt), device::ReportScaling{},
                                                      fault);
    if (!opt.sim_push.empty()) sim->device().set_push(device::parse_sim_push(opt.sim_push));
    return sim;
  }
  const auto sim_only = [](bool given, const char* option) {
    if (given) throw Error(std::string(option) + " needs --device sim", {}, 0, option);
  };
  sim_only(!opt.sim_fault.empty(), "--sim-fault");
  sim_only(!opt.sim_effects.empty(), "--sim-effect");
  sim_only(!opt.sim_push.empty(), "--sim-push");
  sim_only(opt.sim_noise_rad > 0.0, "--sim-noise");
  if (opt.device.rfind("hid", 0) == 0) {
    return std::make_unique<device::HidTransport>(
        device::HidDeviceSpec::parse(opt.device.substr(3), "--device"));
  }
  throw Error("expected sim, hid, hid:VID:PID or hid:PATH, got '" + opt.device + "'", {}, 0,
              "--device");
}

}  // namespace

LoopSetup make_loop_setup(const Options& opt) {
  LoopSetup setup;
  setup.config = make_loop_config(opt, setup.model_source, setup.model_note);
  setup.transport = make_transport(opt);
  return setup;
}

device::LoopCommand make_run_command(const Options& opt, std::uint32_t run_id) {
  device::LoopCommand c;
  c.kind = device::LoopCommand::Kind::kRun;
  c.run_id = run_id;
  c.duration_s = opt.duration_s;
  c.wave.kind = opt.wave.value();
  c.wave.amplitude_rad = opt.amplitude_rad;
  c.wave.freq_hz = opt.freq_hz;
  return c;
}

device::RunRecording make_recording(const Options& opt, const device::LoopCommand& run,
                                    const LoopSetup& setup) {
  device::RunRecording rec;
  rec.dir = opt.record_dir;
  rec.wave = run.wave;
  // dataset.json is JSON: text that came from the command line is made valid UTF-8 here.
  rec.command_line = protocol::sanitize_utf8(opt.command_line);
  rec.device = protocol::sanitize_utf8(setup.transport->describe());
  rec.model_source = protocol::sanitize_utf8(setup.model_source);
  rec.force = opt.force_record;
  return rec;
}

std::string default_socket_path() {
  if (const char* xdg = std::getenv("XDG_RUNTIME_DIR"); xdg != nullptr && *xdg == '/') {
    return std::string(xdg) + "/alphainv/omni_ctl.sock";
  }
  return "/tmp/alphainv-" + std::to_string(getuid()) + "/omni_ctl.sock";
}

}  // namespace omni_ctl
