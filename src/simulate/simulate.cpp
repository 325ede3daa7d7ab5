#include "alphainv/simulate/simulate.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>

#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include "alphainv/model/alpha.hpp"
#include "alphainv/model/plant_input.hpp"
#include "alphainv/error.hpp"
#include "alphainv/simulate/virtual_omni.hpp"

namespace alphainv {

namespace {

using State = std::array<double, 3>;  // θ, Φ = θ̇, z = ∫e dt

/// Everything the right-hand side of (43) yields at one instant.
struct RhsValue {
  State dx{};
  double v = 0.0, alpha = 0.0, damping = 0.0, beta_tilde = 0.0;
};

/// The closed loop (43) with the PID law (10); α by the fixed point (44)-(46).
class ClosedLoop {
 public:
  /// `open_loop`: the reference is the command v(t) (simulate_open_loop), not the controller's r.
  ClosedLoop(const JointModelAtPose& model, const Controller& controller, bool open_loop,
             const SimulationOptions& options, const KnownInputSeries& known,
             SimulationResult& stats)
      : model_(model), ctl_(controller), open_loop_(open_loop), opt_(options), known_(known),
        stats_(stats), alpha_at_(model.alpha.at_inertia(model.inertia)) {}

  /// v(t − τ) of the command history (the command before the first entry is the first one),
  /// linear between its entries. A t − τ after the last entry (τ shorter than the step being
  /// taken) lies between the command at the step's start and the command v_now at t: linear
  /// between them too, so that the delay line's error is that of the history's interpolation,
  /// O(h²·v̈) for steps h, whatever τ, and v(t − τ) tends to v_now as τ → 0 (no delay).
  double delayed_command(double t, double v_now) const {
    if (!(model_.effects.delay_s > 0.0) || history_t_.empty()) return v_now;
    const double td = t - model_.effects.delay_s;
    if (td <= history_t_.front()) return history_v_.front();
    if (td >= history_t_.back()) {
      const double since_last_s = t - history_t_.back();
      if (!(since_last_s > 0.0)) return history_v_.back();
      const double w = (td - history_t_.back()) / since_last_s;
      return (1.0 - w) * history_v_.back() + w * v_now;
    }
    const auto it = std::upper_bound(history_t_.begin(), history_t_.end(), td);
    const std::size_t j = static_cast<std::size_t>(it - history_t_.begin());
    const double w = (td - history_t_[j - 1]) / (history_t_[j] - history_t_[j - 1]);
    return (1.0 - w) * history_v_[j - 1] + w * history_v_[j];
  }

  /// Appends the command at the start of an accepted step (for the delay).
  void commit(double t, double v) {
    if (!(model_.effects.delay_s > 0.0)) return;
    if (!history_t_.empty() && t <= history_t_.back()) return;
    history_t_.push_back(t);
    history_v_.push_back(v);
  }

  /// The known inputs at t (zero-order hold of their samples).
  KnownInputs known_at(double t) const noexcept { return known_.at(t); }

  RhsValue eval(double t, const ReferenceSample& ref, const State& x) {
    return eval(t, ref, x, known_.at(t));
  }

  RhsValue eval(double t, const ReferenceSample& ref, const State& x, const KnownInputs& known) {
    ++stats_.rhs_evaluations;
    const double theta = x[0], phi = x[1], z = x[2];
    const double e = ref.r - theta;
    const bool d_on_err = ctl_.derivative_on == DerivativeOn::kError;
    const double d = d_on_err ? ref.r_dot - phi : -phi;
    // A known addition c(t) to the command (a compensated run's v_comp, KnownInputs) is the
    // controller's: before the clamp.
    const double v_raw = open_loop_ ? ref.r
                                    : ctl_.kp * e + ctl_.ki * z + ctl_.kd * d + known.command_offset_v;
    const double v = open_loop_ ? v_raw : ctl_.clamp(v_raw);
    const bool saturated = v != v_raw;
    // v̇ and v̈ as functions of the unknown Φ̇ (eq. (44)); in open loop those of the recorded
    // command. The kd contribution to v̈ needs r⃛ and Φ̈, which the scheme does not carry; it is
    // dropped (exact for kd = 0, the paper's case). So is c(t)'s, held between its samples (the
    // digital loop, which recordings on the loop grid use, has its α from the whole command).
    auto v_dot_of = [&](double phi_dot) {
      if (open_loop_) return ref.r_dot;
      if (saturated) return 0.0;
      return ctl_.kp * (ref.r_dot - phi) + ctl_.ki * e +
             ctl_.kd * (d_on_err ? ref.r_ddot - phi_dot : -phi_dot);
    };
    auto v_ddot_of = [&](double phi_dot) {
      if (open_loop_) return ref.r_ddot;
      if (saturated) return 0.0;
      return ctl_.kp * (ref.r_ddot - phi_dot) + ctl_.ki * (ref.r_dot - phi);
    };
    RhsValue out;
    out.v = v;
    // The applied input u of plant_input.hpp: the command through delay, deadzone, saturation and
    // the motor enable, plus the torques n(θ, Φ) + d(t). α stays that of the controller's command,
    // 0 while the motor is off (the joint receives no command energy, as in the virtual plant).
    const double u = plant_input(model_.effects, t, delayed_command(t, v), theta, phi, known);
    double c = model_.c_linear, b = model_.beta_tilde_linear;
    double phi_dot = -c * phi + b * u;  // eq. (45) with erratum 4: the linear-model Φ̇
    double alpha =
        known.torque_enabled ? alpha_instantaneous(v, v_dot_of(phi_dot), v_ddot_of(phi_dot)) : 0.0;
    if (model_.use_alpha && !known.torque_enabled) {
      c = alpha_at_.damping(alpha);
      b = alpha_at_.beta_tilde(alpha);
      phi_dot = -c * phi + b * u;
    } else if (model_.use_alpha) {
      int it = 0;
      for (;;) {
        c = alpha_at_.damping(alpha);
        b = alpha_at_.beta_tilde(alpha);
        phi_dot = -c * phi + b * u;  // eq. (44)
        const double next = alpha_instantaneous(v, v_dot_of(phi_dot), v_ddot_of(phi_dot));
        ++it;
        const bool converged =
            std::abs(next - alpha) < std::max(opt_.alpha_abs_tol, opt_.alpha_rel_tol * std::abs(next));
        alpha = next;
        if (converged || it >= opt_.max_iterations) {
          if (!converged) ++stats_.fixed_point_not_converged;
          break;
        }
      }
      // Coefficients consistent with the final α (eq. (46) met).
      c = alpha_at_.damping(alpha);
      b = alpha_at_.beta_tilde(alpha);
      phi_dot = -c * phi + b * u;
      stats_.fixed_point_iterations += it;
      stats_.max_fixed_point_iterations = std::max(stats_.max_fixed_point_iterations, it);
    }
    out.alpha = alpha;
    out.damping = c;
    out.beta_tilde = b;
    out.dx = {phi, phi_dot, open_loop_ ? 0.0 : e};
    return out;
  }

 private:
  const JointModelAtPose& model_;
  const Controller& ctl_;
  const bool open_loop_;
  const SimulationOptions& opt_;
  const KnownInputSeries& known_;
  SimulationResult& stats_;
  /// Coefficients at the run's inertia, computed once (eq. (40), (42)).
  AlphaModelAtInertia alpha_at_;
  std::vector<double> history_t_, history_v_;  ///< command history (delay only)
};

/// Reference value at t; at the right end of a segment that ends in a jump, the left limit.
ReferenceSample ref_at(const Reference& ref, double t, double segment_end, bool end_is_jump) {
  if (end_is_jump && t >= segment_end - 1e-12 * std::max(1.0, std::abs(segment_end))) {
    return ref.at(segment_end - 1e-9 * std::max(1.0, std::abs(segment_end)));
  }
  return ref.at(t);
}

void record(SimulationResult& res, double t, const State& x, const RhsValue& f) {
  res.t.push_back(t);
  res.theta.push_back(x[0]);
  res.theta_dot.push_back(x[1]);
  res.v.push_back(f.v);
  res.alpha.push_back(f.alpha);
  res.damping.push_back(f.damping);
  res.beta_tilde.push_back(f.beta_tilde);
}

/// Splits [t0, t1] at the reference's discontinuities: returns segment end points (ascending).
std::vector<double> segment_ends(const Reference& ref, double t0, double t1) {
  std::vector<double> jumps;
  ref.discontinuities(t0, t1, jumps);
  jumps.push_back(t1);
  std::sort(jumps.begin(), jumps.end());
  jumps.erase(std::unique(jumps.begin(), jumps.end()), jumps.end());
  return jumps;
}

bool state_finite(const State& x) {
  return std::isfinite(x[0]) && std::isfinite(x[1]) && std::isfinite(x[2]);
}

void simulate_rk4(ClosedLoop& loop, const Reference& ref, const std::vector<double>& times,
                  State x, const SimulationOptions& opt, SimulationResult& res) {
  record(res, times[0], x, loop.eval(times[0], ref.at(times[0]), x));
  // The step does not depend on a delay τ: delayed_command() interpolates v(t − τ) inside the
  // step too. (Steps bounded by τ made a simulation cost O(1/τ): a fit whose Jacobian stepped τ
  // from its bound 0 to 2e-8 s simulated 10⁸ steps a run.)
  const double max_step = opt.max_step_s;
  for (std::size_t k = 0; k + 1 < times.size(); ++k) {
    double t = times[k];
    const std::vector<double> ends = segment_ends(ref, times[k], times[k + 1]);
    for (std::size_t s = 0; s < ends.size(); ++s) {
      const double seg_end = ends[s];
      const bool end_is_jump = s + 1 < ends.size() || seg_end != times[k + 1];
      const double span = seg_end - t;
      if (span <= 0.0) continue;
      const int steps = std::max(1, static_cast<int>(std::ceil(span / max_step - 1e-9)));
      const double h = span / steps;
      for (int i = 0; i < steps; ++i) {
        const double ts = t + i * h;
        const KnownInputs known = loop.known_at(ts + 0.5 * h);  // held over the step
        auto f = [&](double tt, const State& xx) {
          return loop.eval(tt, ref_at(ref, tt, seg_end, end_is_jump), xx, known).dx;
        };
        const RhsValue f1 = loop.eval(ts, ref_at(ref, ts, seg_end, end_is_jump), x, known);
        loop.commit(ts, f1.v);
        const State k1 = f1.dx;
        State x2, x3, x4;
        for (int j = 0; j < 3; ++j) x2[j] = x[j] + 0.5 * h * k1[j];
        const State k2 = f(ts + 0.5 * h, x2);
        for (int j = 0; j < 3; ++j) x3[j] = x[j] + 0.5 * h * k2[j];
        const State k3 = f(ts + 0.5 * h, x3);
        for (int j = 0; j < 3; ++j) x4[j] = x[j] + h * k3[j];
        const State k4 = f(ts + h, x4);
        for (int j = 0; j < 3; ++j) x[j] += h / 6.0 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]);
      }
      t = seg_end;
    }
    if (!state_finite(x)) {
      res.message = "the state became non-finite at t = " + std::to_string(times[k + 1]) + " s";
      return;
    }
    record(res, times[k + 1], x, loop.eval(times[k + 1], ref.at(times[k + 1]), x));
  }
  res.ok = true;
}

struct CvodeUser {
  ClosedLoop* loop;
  const Reference* ref;
  double segment_end;
  bool end_is_jump;
};

int cvode_rhs(sunrealtype t, N_Vector y, N_Vector ydot, void* user) {
  auto* u = static_cast<CvodeUser*>(user);
  const double* yy = N_VGetArrayPointer(y);
  const State x{yy[0], yy[1], yy[2]};
  if (!state_finite(x)) return 1;  // recoverable: CVODE retries with a smaller step
  const RhsValue f = u->loop->eval(t, ref_at(*u->ref, t, u->segment_end, u->end_is_jump), x);
  double* dd = N_VGetArrayPointer(ydot);
  dd[0] = f.dx[0];
  dd[1] = f.dx[1];
  dd[2] = f.dx[2];
  return 0;
}

/// RAII for the SUNDIALS objects.
struct CvodeHandles {
  SUNContext ctx = nullptr;
  N_Vector y = nullptr;
  SUNMatrix a = nullptr;
  SUNLinearSolver ls = nullptr;
  void* mem = nullptr;
  ~CvodeHandles() {
    if (mem) CVodeFree(&mem);
    if (ls) SUNLinSolFree(ls);
    if (a) SUNMatDestroy(a);
    if (y) N_VDestroy(y);
    if (ctx) SUNContext_Free(&ctx);
  }
};

void simulate_cvode(ClosedLoop& loop, const Reference& ref, const std::vector<double>& times,
                    State x, const SimulationOptions& opt, SimulationResult& res) {
  CvodeHandles h;
  if (SUNContext_Create(nullptr, &h.ctx) != 0) {
    res.message = "SUNContext_Create failed";
    return;
  }
  h.y = N_VNew_Serial(3, h.ctx);
  double* yy = N_VGetArrayPointer(h.y);
  for (int j = 0; j < 3; ++j) yy[j] = x[static_cast<std::size_t>(j)];
  h.mem = CVodeCreate(CV_BDF, h.ctx);
  CvodeUser user{&loop, &ref, times.back(), false};
  if (!h.mem || CVodeInit(h.mem, cvode_rhs, times[0], h.y) != CV_SUCCESS ||
      CVodeSStolerances(h.mem, opt.cvode_rel_tol, opt.cvode_abs_tol) != CV_SUCCESS) {
    res.message = "CVODE initialisation failed";
    return;
  }
  h.a = SUNDenseMatrix(3, 3, h.ctx);
  h.ls = SUNLinSol_Dense(h.y, h.a, h.ctx);
  CVodeSetLinearSolver(h.mem, h.ls, h.a);
  CVodeSetUserData(h.mem, &user);
  CVodeSetMaxNumSteps(h.mem, 1000000);
  CVodeSetMaxStep(h.mem, std::max(opt.max_step_s, 1e-6));

  record(res, times[0], x, loop.eval(times[0], ref.at(times[0]), x));
  const std::vector<double> ends = segment_ends(ref, times.front(), times.back());
  std::size_t k = 1;
  double t_now = times[0];
  for (std::size_t s = 0; s < ends.size(); ++s) {
    user.segment_end = ends[s];
    user.end_is_jump = s + 1 < ends.size();
    CVodeSetStopTime(h.mem, ends[s]);
    if (s > 0) CVodeReInit(h.mem, t_now, h.y);
    // Outputs inside this segment (and one exactly at its end).
    while (k < times.size() && times[k] <= ends[s]) {
      double t_ret = t_now;
      const int flag = CVode(h.mem, times[k], h.y, &t_ret, CV_NORMAL);
      if (flag < 0) {
        res.message = "CVODE failed at t = " + std::to_string(t_ret) + " s (flag " +
                      std::to_string(flag) + ")";
        return;
      }
      t_now = t_ret;
      const State xs{yy[0], yy[1], yy[2]};
      record(res, times[k], xs, loop.eval(times[k], ref.at(times[k]), xs));
      ++k;
    }
    if (t_now < ends[s]) {
      double t_ret = t_now;
      const int flag = CVode(h.mem, ends[s], h.y, &t_ret, CV_NORMAL);
      if (flag < 0) {
        res.message = "CVODE failed at t = " + std::to_string(t_ret) + " s";
        return;
      }
      t_now = t_ret;
    }
  }
  res.ok = true;
}

/// The digital loop (file comment of simulate.hpp): the plant of virtual_omni.hpp with the model's
/// C, β̃ and effects, no measurement effects, driven by the sampled PID law of run_closed_loop.
void simulate_digital(const JointModelAtPose& model, const Controller& ctl, bool open_loop,
                      const Reference& ref, const std::vector<double>& times,
                      const InitialState& init,
                      const SimulationOptions& opt, const KnownInputSeries& known,
                      SimulationResult& res) {
  const double T = opt.loop_period_s;
  const double t0 = times.front();
  VirtualOmniParams p;
  p.inertia = InertiaModel{model.inertia, 0.0, 0.0, 0.0, 0.0};  // I at any pose = model.inertia
  p.gamma1_deg = p.gamma2_deg = 0.0;
  p.alpha_model = model.use_alpha
                      ? model.alpha
                      : constant_alpha_model(1.0 / (model.c_linear * model.inertia),
                                             1.0 / (model.beta_tilde_linear * model.inertia));
  p.alpha_filter.sample_period_s = T;
  p.alpha_filter.cutoff_hz = loop_alpha_cutoff_hz(opt);
  p.tick_period_s = T;
  p.initial_theta_rad = init.theta;
  p.initial_theta_dot_rad_s = init.theta_dot;
  const ReferenceSample r0 = ref.at(t0);
  p.initial_command_v =
      !init.command_history.empty()
          ? init.command_history.front()
          : (open_loop ? r0.r
                       : ctl.clamp(ctl.kp * (r0.r - init.theta) + ctl.ki * init.integral +
                                   known.at(t0).command_offset_v));
  p.effects = model.effects;
  p.exact_constant_segments = true;  // the exact segment where n is free of the state
  p.precomputed_torque = true;       // n by TorqueEffects (equal to effect_torque to rounding)
  std::unique_ptr<VirtualOmni> omni;
  std::string last_error;
  const int substeps = model_simulation_substeps(p);  // as many as the stiffest effect needs
  p.substeps = substeps > 0 ? substeps : 1000;  // none stable: the constructor says why
  try {
    omni = std::make_unique<VirtualOmni>(p);
  } catch (const Error& e) {
    last_error = e.what();
  }
  if (!omni) {
    res.message = "digital loop: " + last_error;
    return;
  }
  if (!init.command_history.empty()) {
    omni->prime_commands(init.command_history.data(), init.command_history.size());
  }
  const double span = times.back() - t0;
  const auto n_ticks = static_cast<std::size_t>(std::ceil(span / T - 1e-9)) + 1;
  if (n_ticks > 100000000) {
    res.message = "digital loop: too many ticks (" + std::to_string(n_ticks) + ")";
    return;
  }
  std::vector<double> tk(n_ticks), th(n_ticks), thd(n_ticks), vk(n_ticks), ak(n_ticks),
      ck(n_ticks), bk(n_ticks);
  double integral = init.integral, e_prev = 0.0, theta_prev = init.theta;
  for (std::size_t k = 0; k < n_ticks; ++k) {
    const double t = t0 + static_cast<double>(k) * T;
    const double theta = omni->theta();
    const double e = ref.at(t).r - theta;
    integral += T * e;
    double d = 0.0;
    if (k > 0) d = ctl.derivative_on == DerivativeOn::kError ? (e - e_prev) / T
                                                             : -(theta - theta_prev) / T;
    const KnownInputs in = known.at(t);
    const double v = open_loop ? ref.at(t).r
                               : ctl.clamp(ctl.kp * e + ctl.ki * integral + ctl.kd * d +
                                           in.command_offset_v);  // c(t): before the clamp
    tk[k] = t;
    th[k] = theta;
    thd[k] = omni->theta_dot();
    vk[k] = v;
    omni->step(v, in);
    ak[k] = omni->alpha();
    ck[k] = omni->damping();
    bk[k] = omni->beta_tilde();
    e_prev = e;
    theta_prev = theta;
    if (!std::isfinite(omni->theta()) || !std::isfinite(omni->theta_dot())) {
      res.message = "the state became non-finite at t = " + std::to_string(t + T) + " s";
      return;
    }
  }
  // Linear interpolation of the tick values onto the requested times.
  std::size_t j = 0;
  for (double t : times) {
    while (j + 2 < n_ticks && tk[j + 1] <= t) ++j;
    double w = n_ticks > 1 ? std::clamp((t - tk[j]) / T, 0.0, 1.0) : 0.0;
    if (w < 1e-9) w = 0.0;  // on a tick, up to rounding
    if (w > 1.0 - 1e-9) w = 1.0;
    const std::size_t j1 = std::min(j + 1, n_ticks - 1);
    auto lerp = [&](const std::vector<double>& y) { return (1.0 - w) * y[j] + w * y[j1]; };
    res.t.push_back(t);
    res.theta.push_back(lerp(th));
    res.theta_dot.push_back(lerp(thd));
    res.v.push_back(w < 1.0 ? vk[j] : vk[j1]);  // held over the tick
    res.alpha.push_back(w < 1.0 ? ak[j] : ak[j1]);
    res.damping.push_back(w < 1.0 ? ck[j] : ck[j1]);
    res.beta_tilde.push_back(w < 1.0 ? bk[j] : bk[j1]);
  }
  res.rhs_evaluations = static_cast<long>(n_ticks);
  res.ok = true;
}

}  // namespace

std::vector<double> uniform_times(double duration_s, double dt_s, double t0_s) {
  std::vector<double> out;
  if (!(dt_s > 0.0) || !(duration_s >= 0.0)) return out;
  const auto n = static_cast<std::size_t>(std::floor(duration_s / dt_s + 0.5)) + 1;
  out.reserve(n);
  for (std::size_t k = 0; k < n; ++k) out.push_back(t0_s + static_cast<double>(k) * dt_s);
  return out;
}

namespace {

/// simulate() and simulate_open_loop(): `reference` is r, or the command v when `open_loop`.
SimulationResult simulate_any(const JointModelAtPose& model, const Controller& controller,
                              bool open_loop, const Reference& reference,
                              const std::vector<double>& times_s, const InitialState& initial,
                              const SimulationOptions& options,
                              const KnownInputSeries& known_inputs) {
  SimulationResult res;
  if (times_s.empty()) {
    res.message = "no output times";
    return res;
  }
  for (std::size_t k = 1; k < times_s.size(); ++k) {
    if (!(times_s[k] > times_s[k - 1])) {
      res.message = "output times must be strictly increasing (index " + std::to_string(k) + ")";
      return res;
    }
  }
  if (model.use_alpha && !model.alpha.valid()) {
    res.message = "invalid alpha model (breakpoints must increase, coefficients be positive)";
    return res;
  }
  if (!(model.inertia > 0.0)) {
    res.message = "inertia must be positive";
    return res;
  }
  const std::size_t n = times_s.size();
  for (auto* v : {&res.t, &res.theta, &res.theta_dot, &res.v, &res.alpha, &res.damping,
                  &res.beta_tilde}) {
    v->reserve(n);
  }
  try {
    validate_effects(model.effects, "model.effects.");
  } catch (const Error& e) {
    res.message = e.what();
    return res;
  }
  if (options.loop_period_s > 0.0) {
    if (!std::isfinite(options.loop_period_s)) {
      res.message = "loop_period_s must be finite";
      return res;
    }
    simulate_digital(model, controller, open_loop, reference, times_s, initial, options,
                     known_inputs, res);
    return res;
  }
  if (discovered_memory_active(model.effects)) {
    res.message = "the discovered term's memory terms (discovered_lag_sign_v, discovered_dahl_v) "
                  "need the digital loop (loop_period_s > 0)";
    return res;
  }
  ClosedLoop loop(model, controller, open_loop, options, known_inputs, res);
  const State x0{initial.theta, initial.theta_dot, initial.integral};
  if (options.integrator == Integrator::kCvode && model.effects.delay_s > 0.0) {
    res.message = "a time delay needs the fixed-point RK4 integrator or the digital loop";
    return res;
  }
  if (options.integrator == Integrator::kCvode) {
    simulate_cvode(loop, reference, times_s, x0, options, res);
  } else {
    simulate_rk4(loop, reference, times_s, x0, options, res);
  }
  return res;
}

}  // namespace

SimulationResult simulate(const JointModelAtPose& model, const Controller& controller,
                          const Reference& reference, const std::vector<double>& times_s,
                          const InitialState& initial, const SimulationOptions& options,
                          const KnownInputSeries& known_inputs) {
  return simulate_any(model, controller, false, reference, times_s, initial, options,
                      known_inputs);
}

SimulationResult simulate_open_loop(const JointModelAtPose& model, const Reference& command,
                                    const std::vector<double>& times_s,
                                    const InitialState& initial, const SimulationOptions& options,
                                    const KnownInputSeries& known_inputs) {
  return simulate_any(model, Controller{}, true, command, times_s, initial, options,
                      known_inputs);
}

}  // namespace alphainv
