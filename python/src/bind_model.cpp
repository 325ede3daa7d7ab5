/// \file bind_model.cpp
/// The core (alphainv::core) in Python: α (eqs. 33, 34, 36), AlphaModel (38)-(42), InertiaModel
/// (6), LinearModel (24)-(26), Controller (10), the effects generated from kEffectCatalogue, and
/// the streaming estimator rt::AlphaEstimator.

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "alphainv/model/alpha.hpp"
#include "alphainv/model/controller.hpp"
#include "alphainv/model/damping_model.hpp"
#include "alphainv/model/effects.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/rt/alpha_estimator.hpp"
#include "bindings.hpp"

namespace alphainv::python {

namespace {

using InArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

const char* role_name(EffectRole r) {
  switch (r) {
    case EffectRole::kNone: return "none";
    case EffectRole::kTorque: return "torque";
    case EffectRole::kInputMap: return "input_map";
    case EffectRole::kDelay: return "delay";
    case EffectRole::kTimeSeries: return "time_series";
  }
  return "none";
}

/// The parameter called `name` in the table, or nullptr.
const EffectParameter* parameter_named(const std::string& name, const EffectSpec** spec = nullptr) {
  for (const EffectSpec& s : kEffectCatalogue) {
    for (const EffectParameter& p : s) {
      if (name == p.name) {
        if (spec) *spec = &s;
        return &p;
      }
    }
  }
  return nullptr;
}

std::string parameter_names() {
  std::string out;
  for (const EffectSpec& s : kEffectCatalogue)
    for (const EffectParameter& p : s) out += (out.empty() ? "" : ", ") + std::string(p.name);
  return out;
}

/// Runs `est` over `v` (reset to v[0] first when `reset`), GIL released. Returns α̂, or a dict
/// of α̂ and the filtered command with its derivatives.
py::object run_estimator(rt::AlphaEstimator& est, const InArray& v, bool derivatives, bool reset) {
  if (v.ndim() != 1) throw Error("expected a 1-D array", {}, 0, "v");
  const auto n = v.shape(0);
  py::array_t<double> alpha(n), w, wd, wdd;
  if (derivatives) w = py::array_t<double>(n), wd = py::array_t<double>(n), wdd = py::array_t<double>(n);
  const double* in = v.data();
  double* a = alpha.mutable_data();
  double* pw = derivatives ? w.mutable_data() : nullptr;
  double* pwd = derivatives ? wd.mutable_data() : nullptr;
  double* pwdd = derivatives ? wdd.mutable_data() : nullptr;
  {
    py::gil_scoped_release release;
    // A local copy: the output arrays cannot alias its state, so it stays in registers.
    rt::AlphaEstimator local = est;
    if (reset && n > 0) local.reset(in[0]);
    if (pw) {
      for (py::ssize_t k = 0; k < n; ++k) {
        const rt::AlphaEstimate e = local.update(in[k]);
        a[k] = e.alpha, pw[k] = e.v, pwd[k] = e.v_dot, pwdd[k] = e.v_ddot;
      }
    } else {
      for (py::ssize_t k = 0; k < n; ++k) a[k] = local.update(in[k]).alpha;
    }
    est = local;
  }
  if (!derivatives) return std::move(alpha);
  py::dict d;
  d["alpha"] = alpha;
  d["v"] = w;
  d["v_dot"] = wd;
  d["v_ddot"] = wdd;
  return std::move(d);
}

std::vector<double> first(const std::array<double, kMaxBreakpoints>& a, std::size_t n) {
  return std::vector<double>(a.begin(), a.begin() + static_cast<std::ptrdiff_t>(n));
}

void set_breakpoint_values(AlphaModel& m, std::array<double, kMaxBreakpoints>& target,
                           py::handle values, const char* field) {
  const std::vector<double> v = to_vector(values, field);
  if (v.size() != m.n_breakpoints) {
    throw Error("expected " + std::to_string(m.n_breakpoints) + " values (one per breakpoint), found " +
                    std::to_string(v.size()),
                {}, 0, field);
  }
  std::copy(v.begin(), v.end(), target.begin());
}

AlphaModel make_alpha_model(py::handle alpha, py::handle c_n1, std::array<double, 2> beta_alpha,
                            std::array<double, 2> beta_n1) {
  const std::vector<double> a = to_vector(alpha, "alpha");
  if (a.size() < 2 || a.size() > kMaxBreakpoints) {
    throw Error("expected 2.." + std::to_string(kMaxBreakpoints) + " breakpoints, found " +
                    std::to_string(a.size()),
                {}, 0, "alpha");
  }
  AlphaModel m;
  m.n_breakpoints = a.size();
  std::copy(a.begin(), a.end(), m.alpha.begin());
  set_breakpoint_values(m, m.c_n1, c_n1, "c_n1");
  m.beta_alpha = beta_alpha;
  m.beta_n1 = beta_n1;
  if (!m.valid()) {
    throw Error("expected increasing breakpoints, C_n1 > 0, beta_alpha increasing and beta_n1 > 0",
                {}, 0, "AlphaModel");
  }
  return m;
}

std::string derivative_name(DerivativeOn d) { return d == DerivativeOn::kError ? "error" : "measurement"; }
DerivativeOn derivative_of(const std::string& s) {
  if (s == "error") return DerivativeOn::kError;
  if (s == "measurement") return DerivativeOn::kMeasurement;
  throw Error("expected \"error\" or \"measurement\", found \"" + s + "\"", {}, 0, "derivative_on");
}

}  // namespace

Effects effects_from(py::handle obj, const std::string& field) {
  Effects e;
  if (obj.is_none()) return e;
  if (py::isinstance<Effects>(obj)) return obj.cast<Effects>();
  if (py::isinstance<py::str>(obj)) {
    apply_effect_spec(obj.cast<std::string>(), e);
    return e;
  }
  if (py::isinstance<py::dict>(obj)) {
    for (auto item : obj.cast<py::dict>()) {
      const std::string key = py::str(item.first);
      if (py::isinstance<py::dict>(item.second)) {  // {effect: {parameter: value}}
        const EffectKind kind = effect_kind_from_name(key, field);
        for (auto p : item.second.cast<py::dict>()) {
          const std::string name = py::str(p.first);
          const EffectSpec* spec = nullptr;
          const EffectParameter* par = parameter_named(name, &spec);
          if (!par || spec->kind != kind) {
            throw Error("not a parameter of " + key, {}, 0, field + "." + key + "." + name);
          }
          e.*(par->member) = p.second.cast<double>();
        }
      } else {  // {parameter: value}
        const EffectParameter* par = parameter_named(key);
        if (!par) throw Error("unknown parameter; expected one of " + parameter_names(), {}, 0, field + "." + key);
        e.*(par->member) = item.second.cast<double>();
      }
    }
    validate_effects(e, field + ".");
    return e;
  }
  if (py::isinstance<py::sequence>(obj)) {
    for (auto item : obj.cast<py::sequence>()) apply_effect_spec(py::cast<std::string>(item), e);
    return e;
  }
  throw Error("expected an Effects, a spec string, a list of spec strings or a dict", {}, 0, field);
}

py::dict effects_dict(const Effects& e) {
  py::dict out;
  for (EffectKind k : active_effects(e)) {
    py::dict params;
    for (const EffectParameter& p : effect_spec(k)) params[p.name] = e.*(p.member);
    out[effect_name(k)] = params;
  }
  return out;
}

void bind_model(py::module_& m) {
  // --- α, eqs. (33), (34), (36) -----------------------------------------------------------------
  m.def(
      "alpha",
      [](const InArray& v, double dt_s, double cutoff_hz, bool derivatives) {
        rt::AlphaEstimatorConfig cfg;
        cfg.sample_period_s = dt_s;
        cfg.cutoff_hz = cutoff_hz;
        rt::AlphaEstimator est(cfg);
        return run_estimator(est, v, derivatives, true);
      },
      py::arg("v"), py::arg("dt"), py::arg("cutoff_hz") = 25.0, py::arg("derivatives") = false,
      R"(The alpha-invariant of a sampled command, eq. (33): alpha = v'^2 - v v''.

The derivatives come from the library's streaming estimator (rt::AlphaEstimator, the one of the
1 kHz loop and the virtual plant): a 3rd-order Butterworth low-pass (cut-off `cutoff_hz`) in
state-variable form whose states are the filtered command and its two derivatives, started at
the steady state of v[0]. For a sine the estimate is |H(f)|^2 A^2 w^2 (docs/alpha-estimator.md).

v: command samples [command unit], 1-D, uniformly spaced by dt [s] (float64 C-contiguous input
is read without a copy). Returns alpha [unit^2/s^2] per sample, or with derivatives=True a dict
of numpy arrays alpha, v, v_dot, v_ddot (filtered). The GIL is released while it runs.
Raises alphainv.Error (field "sample_period_s" or "cutoff_hz") for dt <= 0 or cutoff_hz not in
(0, 0.25/dt).)");
  m.def("alpha_instantaneous", py::vectorize([](double v, double vd, double vdd) { return alpha_instantaneous(v, vd, vdd); }), py::arg("v"), py::arg("v_dot"),
        py::arg("v_ddot"),
        "Eq. (33): alpha = v_dot^2 - v*v_ddot [unit^2/s^2], elementwise over arrays.");
  m.def(
      "alpha_cycle_average",
      [](const InArray& v, const InArray& v_dot, const InArray& v_ddot, double dt_s) {
        if (v.size() != v_dot.size() || v.size() != v_ddot.size())
          throw Error("v, v_dot and v_ddot must have the same length", {}, 0, "v_dot");
        return alpha_cycle_average(v.data(), v_dot.data(), v_ddot.data(),
                                   static_cast<std::size_t>(v.size()), dt_s);
      },
      py::arg("v"), py::arg("v_dot"), py::arg("v_ddot"), py::arg("dt"),
      "Eq. (34): the cycle-average alpha over one period sampled uniformly (trapezoidal rule).");
  m.def("alpha_sine_steady_state", py::vectorize([](double kp, double w, double a1, double a2, double ar) {
          return alpha_sine_steady_state(kp, w, a1, a2, ar);
        }), py::arg("kp"),
        py::arg("omega_rad_s"), py::arg("a1"), py::arg("a2"), py::arg("ar"),
        "Eq. (36): alpha = kp^2 w^2 (A1^2 + (Ar - A2)^2) of the sinusoidal steady state under a "
        "P law, theta = A1 cos wt + A2 sin wt (eq. 14) for r = Ar sin wt.");

  // --- AlphaModel, eqs. (38)-(42) -----------------------------------------------------------------
  py::class_<AlphaModel>(m, "AlphaModel", R"(The alpha-invariant model of one joint, eqs. (38)-(42).

Damping C(alpha, I): at breakpoint alpha_n, C_n(I) = 1/(C_n1 I) (eq. 40), linear in alpha
between breakpoints (eq. 38 for N = 4), held outside. Torque constant beta~(alpha, I) (41)-(42):
linear between beta_alpha[0] and beta_alpha[1] with beta~_n(I) = 1/(beta_n1[n] I).
Units: alpha [command unit^2/s^2], I normalised (beta-bar = 1), C [1/s], beta~ [rad/s^2 per unit].)")
      .def(py::init(&make_alpha_model), py::arg("alpha"), py::arg("c_n1"),
           py::arg("beta_alpha") = std::array<double, 2>{0.0, 1.0},
           py::arg("beta_n1") = std::array<double, 2>{1.0, 1.0},
           "alpha: breakpoints alpha_0 < ... (2..8); c_n1: one C_n1 > 0 per breakpoint.")
      .def_static("paper", &paper_alpha_model,
                  "The paper's model (Tables 6-7, paper-notes erratum 3); at I = 0.004366 it "
                  "gives Table 10.")
      .def_readonly("n_breakpoints", &AlphaModel::n_breakpoints)
      .def_property_readonly("alpha", [](const AlphaModel& a) { return to_array(first(a.alpha, a.n_breakpoints)); },
                             "breakpoints alpha_n [command unit^2/s^2] (a copy)")
      .def_property(
          "c_n1", [](const AlphaModel& a) { return to_array(first(a.c_n1, a.n_breakpoints)); },
          [](AlphaModel& a, py::handle v) { set_breakpoint_values(a, a.c_n1, v, "c_n1"); },
          "C_n1 of eq. (40), one per breakpoint (a copy; assign a whole array to change it)")
      .def_readwrite("beta_alpha", &AlphaModel::beta_alpha, "alpha-bar_0 < alpha-bar_1 of eq. (41)")
      .def_readwrite("beta_n1", &AlphaModel::beta_n1, "beta~_n1 of eq. (42)")
      .def("damping", py::vectorize([](AlphaModel a, double x, double i) { return a.damping(x, i); }), py::arg("alpha"), py::arg("inertia"),
           "C(alpha, I) [1/s], eqs. (38)-(40), elementwise.")
      .def("beta_tilde", py::vectorize([](AlphaModel a, double x, double i) { return a.beta_tilde(x, i); }), py::arg("alpha"), py::arg("inertia"),
           "beta~(alpha, I) [rad/s^2 per command unit], eqs. (41)-(42), elementwise.")
      .def("valid", &AlphaModel::valid,
           "True when 2 <= N <= 8, breakpoints increase and every C_n1, beta_n1 is positive.")
      .def("__repr__",
           [](const AlphaModel& a) {
             return "AlphaModel(alpha=" + std::string(py::repr(to_array(first(a.alpha, a.n_breakpoints)))) +
                    ", c_n1=" + std::string(py::repr(to_array(first(a.c_n1, a.n_breakpoints)))) + ")";
           })
      .def(py::pickle(
          [](const AlphaModel& a) {
            return py::make_tuple(first(a.alpha, a.n_breakpoints), first(a.c_n1, a.n_breakpoints),
                                  a.beta_alpha, a.beta_n1);
          },
          [](py::tuple t) {
            return make_alpha_model(t[0], t[1], t[2].cast<std::array<double, 2>>(),
                                    t[3].cast<std::array<double, 2>>());
          }));

  // --- InertiaModel (6), LinearModel (24)-(26) ----------------------------------------------------
  py::class_<InertiaModel>(m, "InertiaModel", R"(The yaw-axis inertia model, eq. (6):
I = I_base + I1 cos^2 g1 + I2 cos^2 psi + I3 cos g1 cos psi, psi = pi - g1 - g2 - gamma_offs.)")
      .def(py::init([](double i_base, double i1, double i2, double i3, double gamma_offs_rad) {
             return InertiaModel{i_base, i1, i2, i3, gamma_offs_rad};
           }),
           py::kw_only(), py::arg("i_base") = 0.0, py::arg("i1") = 0.0, py::arg("i2") = 0.0,
           py::arg("i3") = 0.0, py::arg("gamma_offs_rad") = 0.0)
      .def_static("paper", &paper_inertia_model, "The paper's model (Table 5's modelled columns).")
      .def_readwrite("i_base", &InertiaModel::i_base, "base inertia [normalised]")
      .def_readwrite("i1", &InertiaModel::i1, "coefficient of cos^2 g1")
      .def_readwrite("i2", &InertiaModel::i2, "coefficient of cos^2 psi")
      .def_readwrite("i3", &InertiaModel::i3, "coefficient of cos g1 cos psi")
      .def_readwrite("gamma_offs_rad", &InertiaModel::gamma_offs_rad, "offset angle [rad]")
      .def("inertia", py::vectorize([](InertiaModel m, double g1, double g2) { return m.inertia(g1, g2); }), py::arg("gamma1_rad"), py::arg("gamma2_rad"),
           "I(g1, g2), eq. (6), elementwise; angles in rad.")
      .def("psi_rad", py::vectorize([](InertiaModel m, double g1, double g2) { return m.psi_rad(g1, g2); }), py::arg("gamma1_rad"), py::arg("gamma2_rad"))
      .def("__repr__", [](const InertiaModel& i) {
        return "InertiaModel(i_base=" + std::to_string(i.i_base) + ", i1=" + std::to_string(i.i1) +
               ", i2=" + std::to_string(i.i2) + ", i3=" + std::to_string(i.i3) +
               ", gamma_offs_rad=" + std::to_string(i.gamma_offs_rad) + ")";
      })
      .def(py::pickle(
          [](const InertiaModel& i) { return py::make_tuple(i.i_base, i.i1, i.i2, i.i3, i.gamma_offs_rad); },
          [](py::tuple t) {
            return InertiaModel{t[0].cast<double>(), t[1].cast<double>(), t[2].cast<double>(),
                                t[3].cast<double>(), t[4].cast<double>()};
          }));

  py::class_<LinearModel>(m, "LinearModel",
                          "The global linear model (24)-(26): C = 1/(C0_bar I), beta~ = 1/I.")
      .def(py::init([](const InertiaModel& inertia, double c0_bar) { return LinearModel{inertia, c0_bar}; }),
           py::arg("inertia"), py::arg("c0_bar"))
      .def_static("paper", &paper_linear_model, "The paper's inertia model with C0_bar = 36.694.")
      .def_readwrite("inertia", &LinearModel::inertia)
      .def_readwrite("c0_bar", &LinearModel::c0_bar, "damping ratio C0_bar of eq. (24)")
      .def("damping", py::vectorize([](LinearModel l, double i) { return l.damping(i); }), py::arg("inertia"), "C_linear(I) [1/s], eq. (24)")
      .def("beta_tilde", py::vectorize([](LinearModel l, double i) { return l.beta_tilde(i); }), py::arg("inertia"),
           "beta~_linear(I), eq. (25)")
      .def(py::pickle([](const LinearModel& l) { return py::make_tuple(l.inertia, l.c0_bar); },
                      [](py::tuple t) { return LinearModel{t[0].cast<InertiaModel>(), t[1].cast<double>()}; }));

  // --- Controller (10) --------------------------------------------------------------------------
  py::class_<Controller>(m, "Controller", R"(The PID law of eq. (10): e = r - theta,
v = kp e + ki int(e) + kd de/dt (or -kd dtheta/dt), clipped to +-v_limit (inf: no limit).)")
      .def(py::init([](double kp, double ki, double kd, const std::string& derivative_on, double v_limit) {
             Controller c;
             c.kp = kp, c.ki = ki, c.kd = kd, c.derivative_on = derivative_of(derivative_on);
             c.v_limit = v_limit;
             return c;
           }),
           py::kw_only(), py::arg("kp") = 2.0, py::arg("ki") = 0.0, py::arg("kd") = 0.0,
           py::arg("derivative_on") = "error", py::arg("v_limit") = HUGE_VAL)
      .def_readwrite("kp", &Controller::kp, "proportional gain [command unit / position unit]")
      .def_readwrite("ki", &Controller::ki, "integral gain [command unit / (position unit s)]")
      .def_readwrite("kd", &Controller::kd, "derivative gain [command unit s / position unit]")
      .def_property(
          "derivative_on", [](const Controller& c) { return derivative_name(c.derivative_on); },
          [](Controller& c, const std::string& s) { c.derivative_on = derivative_of(s); },
          "\"error\" or \"measurement\"")
      .def_readwrite("v_limit", &Controller::v_limit, "command limit [command unit]; inf: none")
      .def("clamp", py::vectorize([](Controller c, double v) { return c.clamp(v); }), py::arg("v"))
      .def("__eq__", [](const Controller& a, const Controller& b) { return a == b; })
      .def("__repr__",
           [](const Controller& c) {
             return "Controller(kp=" + std::string(py::repr(py::float_(c.kp))) + ", ki=" +
                    std::string(py::repr(py::float_(c.ki))) + ", kd=" +
                    std::string(py::repr(py::float_(c.kd))) + ", derivative_on='" +
                    derivative_name(c.derivative_on) + "', v_limit=" +
                    std::string(py::repr(py::float_(c.v_limit))) + ")";
           })
      .def(py::pickle(
          [](const Controller& c) {
            return py::make_tuple(c.kp, c.ki, c.kd, derivative_name(c.derivative_on), c.v_limit);
          },
          [](py::tuple t) {
            Controller c;
            c.kp = t[0].cast<double>(), c.ki = t[1].cast<double>(), c.kd = t[2].cast<double>();
            c.derivative_on = derivative_of(t[3].cast<std::string>());
            c.v_limit = t[4].cast<double>();
            return c;
          }));

  // --- the effects, generated from the one table kEffectCatalogue --------------------------------
  py::class_<EffectParameter>(m, "EffectParameter", "One parameter of an effect (kEffectCatalogue).")
      .def_property_readonly("name", [](const EffectParameter& p) { return p.name; })
      .def_property_readonly("unit", [](const EffectParameter& p) { return p.unit; })
      .def_property_readonly("description", [](const EffectParameter& p) { return p.description; })
      .def_property_readonly("modelling_choice", [](const EffectParameter& p) { return p.modelling_choice; })
      .def("__repr__", [](const EffectParameter& p) {
        return std::string("EffectParameter('") + p.name + "', unit='" + p.unit + "')";
      });
  py::class_<EffectSpec>(m, "EffectSpec", "One effect of the catalogue (kEffectCatalogue).")
      .def_property_readonly("name", [](const EffectSpec& s) { return s.name; })
      .def_property_readonly("description", [](const EffectSpec& s) { return s.description; })
      .def_property_readonly("role", [](const EffectSpec& s) { return role_name(s.role); },
                             "\"none\", \"torque\" (a term of n), \"input_map\" (amplifier) or \"delay\"")
      .def_property_readonly(
          "parameters",
          [](const EffectSpec& s) {
            py::list out;
            for (const EffectParameter& p : s) out.append(py::cast(&p, py::return_value_policy::reference));
            return py::tuple(out);
          })
      .def_property_readonly("sweep_magnitudes", [](const EffectSpec& s) { return s.sweep_magnitudes; },
                             "the two magnitudes of the first parameter omni_fit sweep hides")
      .def(
          "sweep_spec",
          [](const EffectSpec& s, int which) {
            if (s.kind == EffectKind::kNone) return std::string();
            if (which < 0 || which > 1) throw Error("expected 0 or 1", {}, 0, "which");
            Effects e;  // the first parameter at the magnitude, the others at their sweep values
            e.*(s.parameters[0].member) = s.sweep_magnitudes[static_cast<std::size_t>(which)];
            for (std::size_t j = 1; j < s.parameter_count; ++j)
              if (!s.parameters[j].modelling_choice) e.*(s.parameters[j].member) = s.parameters[j].sweep_fixed;
            return effect_spec_text(e, s.kind);
          },
          py::arg("which") = 0,
          "The spec string of the effect as omni_fit sweep hides it (magnitude `which`, the other "
          "parameters at their fixed sweep values); '' for none.")
      .def("__repr__", [](const EffectSpec& s) { return std::string("EffectSpec('") + s.name + "')"; });
  {
    py::list specs;
    for (const EffectSpec& s : kEffectCatalogue) specs.append(py::cast(&s, py::return_value_policy::reference));
    m.attr("EFFECTS") = py::tuple(specs);
  }

  std::string effects_doc =
      "Parameters of the effects beyond the alpha-model (effects.hpp), added to eq. (11):\n"
      "theta'' + C theta' = beta~ (S(Z(v(t - tau))) + n(theta, theta')). Every effect is off at\n"
      "its default. Effects(coulomb_v=0.004, ...) sets parameters by name; Effects.parse(spec)\n"
      "reads the command-line form. Generated from kEffectCatalogue:\n";
  for (const EffectSpec& s : kEffectCatalogue) {
    if (s.kind == EffectKind::kNone) continue;
    effects_doc += std::string("\n  ") + s.name + ": " + s.description;
    for (const EffectParameter& p : s) effects_doc += std::string("\n    ") + p.name + " [" + p.unit + "]: " + p.description;
  }
  py::class_<Effects> effects(m, "Effects", effects_doc.c_str());
  effects
      .def(py::init([](py::kwargs kw) { return effects_from(kw, "Effects"); }),
           "Effects(**parameters): parameters by their table names, e.g. coulomb_v=0.004.")
      .def_static("parse", [](py::handle spec) { return effects_from(spec, "spec"); }, py::arg("spec"),
                  "From \"NAME:PARAM=VALUE[,PARAM=VALUE]\" or \"NAME=VALUE\" (as omni_fit fit "
                  "--effect), a list of them, or a dict {effect: {parameter: value}}.")
      .def(
          "apply",
          [](Effects& e, const std::string& spec) -> Effects& {
            apply_effect_spec(spec, e, "spec " + spec);
            return e;
          },
          py::arg("spec"), py::return_value_policy::reference_internal,
          "Sets one effect from a spec string (apply_effect_spec); returns self.")
      .def_property_readonly(
          "active", [](const Effects& e) {
            std::vector<std::string> out;
            for (EffectKind k : active_effects(e)) out.push_back(effect_name(k));
            return out;
          },
          "names of the effects switched on, in catalogue order")
      .def("spec_text",
           [](const Effects& e, const std::string& name) { return effect_spec_text(e, effect_kind_from_name(name)); },
           py::arg("effect"), "The spec string that reads back to this effect's parameters.")
      .def("validate", [](const Effects& e) { validate_effects(e); },
           "Raises alphainv.Error naming the field (\"effects.coulomb_v\") of a value out of range.")
      .def("torque", py::vectorize([](Effects e, double theta, double theta_dot) {
             return effect_torque(e, theta, theta_dot);
           }),
           py::arg("theta"), py::arg("theta_dot"), "n(theta, theta') [command unit], elementwise")
      .def("amplifier", py::vectorize([](Effects e, double v) { return amplifier(e, v); }), py::arg("v"),
           "S(Z(v)): deadzone then saturation [command unit], elementwise")
      .def("to_dict", &effects_dict, "{effect: {parameter: value}} of the active effects")
      .def("__eq__",
           [](const Effects& a, const Effects& b) {
             for (const EffectSpec& s : kEffectCatalogue)
               for (const EffectParameter& p : s)
                 if (!(a.*(p.member) == b.*(p.member))) return false;
             return true;
           })
      .def("__repr__", [](const Effects& e) { return "Effects(" + effects_text(e) + ")"; })
      .def(py::pickle([](const Effects& e) { return effects_dict(e); },
                      [](py::dict d) { return effects_from(d, "effects"); }));
  for (const EffectSpec& s : kEffectCatalogue) {
    for (const EffectParameter& p : s) {
      double Effects::*member = p.member;
      const std::string doc = std::string(p.description) + " [" + p.unit + "] (" + s.name + ")";
      effects.def_property(
          p.name, [member](const Effects& e) { return e.*member; },
          [member](Effects& e, double x) { e.*member = x; }, doc.c_str());
    }
  }

  // --- the streaming estimator -----------------------------------------------------------------
  py::class_<rt::AlphaEstimator>(m, "AlphaEstimator", R"(The streaming alpha estimator of the 1 kHz
tick (rt/alpha_estimator.hpp): one command sample in, the filtered command, its derivatives and
alpha = v'^2 - v v'' (eq. 33) out. 3rd-order Butterworth in state-variable form, first-order hold.)")
      .def(py::init([](double sample_period_s, double cutoff_hz) {
             rt::AlphaEstimatorConfig c;
             c.sample_period_s = sample_period_s, c.cutoff_hz = cutoff_hz;
             return rt::AlphaEstimator(c);
           }),
           py::arg("sample_period_s") = 1e-3, py::arg("cutoff_hz") = 25.0)
      .def("reset", &rt::AlphaEstimator::reset, py::arg("v0") = 0.0,
           "Steady state of a constant command v0.")
      .def(
          "update",
          [](rt::AlphaEstimator& e, double v) {
            const rt::AlphaEstimate x = e.update(v);
            return py::make_tuple(x.v, x.v_dot, x.v_ddot, x.alpha);
          },
          py::arg("v"), "Feeds one sample; returns (v, v_dot, v_ddot, alpha).")
      .def(
          "run",
          [](rt::AlphaEstimator& e, const InArray& v, bool derivatives) {
            return run_estimator(e, v, derivatives, false);
          },
          py::arg("v"), py::arg("derivatives") = false,
          "Feeds every sample of v from the current state (GIL released); returns alpha per "
          "sample, or a dict of alpha, v, v_dot, v_ddot.")
      .def_property_readonly("warmed_up", &rt::AlphaEstimator::warmed_up)
      .def_property_readonly("warmup_ticks", &rt::AlphaEstimator::warmup_ticks)
      .def_property_readonly("delay_s", &rt::AlphaEstimator::delay_s, "group delay at DC, 2/wc [s]")
      .def("alpha_gain", py::vectorize([](rt::AlphaEstimator e, double f) { return e.alpha_gain(f); }), py::arg("freq_hz"),
           "|H(f)|^2: the factor by which alpha of a sine of frequency f under-reads")
      .def("noise_gain", [](const rt::AlphaEstimator& e) {
        const rt::AlphaNoiseGain g = e.noise_gain();
        py::dict d;
        d["v"] = g.v, d["v_dot"] = g.v_dot, d["v_ddot"] = g.v_ddot;
        return d;
      });
}

}  // namespace alphainv::python
