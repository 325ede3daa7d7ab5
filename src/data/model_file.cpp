#include "alphainv/data/model_file.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "alphainv/error.hpp"
#include "common/atomic_file.hpp"
#include "common/format.hpp"
#include "read_file.hpp"

namespace alphainv {

namespace {

using nlohmann::json;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

json num(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }

double get_num(const json& obj, const char* key, const std::string& file, const std::string& path,
               bool allow_null = false) {
  if (!obj.is_object() || !obj.contains(key)) {
    throw Error("missing key", file, 0, path + key);
  }
  const json& v = obj.at(key);
  if (v.is_null() && allow_null) return kNaN;
  if (!v.is_number()) throw Error("expected a number, found " + v.dump(), file, 0, path + key);
  const double x = v.get<double>();
  if (!std::isfinite(x)) throw Error("expected a finite number", file, 0, path + key);
  return x;
}

template <std::size_t N>
std::array<double, N> get_array(const json& obj, const char* key, std::size_t n,
                                const std::string& file, const std::string& path, bool allow_null) {
  std::array<double, N> out{};
  out.fill(kNaN);
  if (!obj.contains(key) || !obj.at(key).is_array()) throw Error("expected an array", file, 0, path + key);
  const json& a = obj.at(key);
  if (a.size() != n) {
    throw Error("expected " + std::to_string(n) + " entries, found " + std::to_string(a.size()), file,
                0, path + key);
  }
  for (std::size_t k = 0; k < n; ++k) {
    if (a[k].is_null() && allow_null) continue;
    if (!a[k].is_number()) throw Error("expected a number", file, 0, path + key + "[" + std::to_string(k) + "]");
    out[k] = a[k].get<double>();
    if (!std::isfinite(out[k])) {
      throw Error("expected a finite number", file, 0, path + key + "[" + std::to_string(k) + "]");
    }
  }
  return out;
}

/// The parameters model.json stores for an effect of `kind`: effect_parameters(kind), and the
/// Coulomb smoothing ε with the Coulomb friction (a modelling choice the simulation needs).
std::vector<EffectParameter> stored_effect_parameters(EffectKind kind) {
  return effect_parameters(kind, /*with_modelling_choices=*/true);
}

json format_effects(const Effects& e) {
  json list = json::array();
  for (EffectKind kind : active_effects(e)) {
    json params = json::object();
    for (const EffectParameter& p : stored_effect_parameters(kind)) {
      // The discovered term lists only its non-zero terms (the others read back as 0).
      if (detail::omitted_when_zero(kind, p) && e.*p.member == 0.0) continue;
      params[p.name] = num(e.*p.member);
    }
    json entry = {{"effect", effect_name(kind)}, {"parameters", params}};
    // Its equation, for the reader (informational: read_model_file reads the parameters).
    if (kind == EffectKind::kDiscovered) entry["equation"] = discovered_equation(e);
    list.push_back(entry);
  }
  return list;
}

/// Reads the "effects" list; every error names `file` and the key path, e.g.
/// effects[1].parameters.delay_s.
Effects parse_effects(const json& list, const std::string& file) {
  Effects effects;
  if (list.is_null()) return effects;
  if (!list.is_array()) throw Error("expected an array of effects, found " + list.dump(), file, 0, "effects");
  std::vector<EffectKind> seen;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string path = "effects[" + std::to_string(i) + "]";
    const json& entry = list[i];
    if (!entry.is_object()) throw Error("expected an object, found " + entry.dump(), file, 0, path);
    if (!entry.contains("effect") || !entry["effect"].is_string()) {
      throw Error("expected a catalogue name (string)", file, 0, path + ".effect");
    }
    EffectKind kind = EffectKind::kNone;
    try {
      kind = effect_kind_from_name(entry["effect"].get<std::string>(), path + ".effect");
    } catch (const Error& e) {
      throw Error(e.message(), file, 0, e.field());
    }
    if (kind == EffectKind::kNone) continue;
    for (EffectKind k : seen) {
      if (k == kind) throw Error("effect listed twice", file, 0, path + ".effect");
    }
    seen.push_back(kind);
    const std::string ppath = path + ".parameters";
    if (!entry.contains("parameters") || !entry["parameters"].is_object()) {
      throw Error("expected an object of parameters", file, 0, ppath);
    }
    const json& params = entry["parameters"];
    const std::vector<EffectParameter> known = stored_effect_parameters(kind);
    for (auto it = params.begin(); it != params.end(); ++it) {
      bool ok = false;
      for (const EffectParameter& p : known) ok = ok || it.key() == p.name;
      if (!ok) {
        std::string names;
        for (const EffectParameter& p : known) names += std::string(names.empty() ? "" : ", ") + p.name;
        throw Error("unknown parameter of " + std::string(effect_name(kind)) + "; expected " + names,
                    file, 0, ppath + "." + it.key());
      }
    }
    // This entry's values on an otherwise default (valid) Effects: validate_effects can then only
    // object to this entry, and its field names the entry's key path.
    Effects one;
    for (const EffectParameter& p : known) {
      const bool optional =
          p.member == &Effects::coulomb_smoothing_rad_s || detail::omitted_when_zero(kind, p);
      if (optional && !params.contains(p.name)) continue;
      one.*p.member = get_num(params, p.name, file, ppath + ".");
    }
    try {
      validate_effects(one, ppath + ".");
    } catch (const Error& e) {
      throw Error(e.message(), file, 0, e.field());
    }
    for (const EffectParameter& p : known) effects.*p.member = one.*p.member;
  }
  return effects;
}

}  // namespace

std::string format_model_file(const ModelFile& m) {
  // Never write what read_model_file would refuse.
  validate_effects(m.effects, "effects.");
  if (!std::isfinite(m.loop_period_s) || m.loop_period_s < 0.0) {
    throw Error("expected loop_period_s >= 0 (0: continuous), got " + std::to_string(m.loop_period_s),
                {}, 0, "simulation.loop_period_s");
  }
  json j;
  j["schema"] = kModelSchema;
  j["tool_version"] = m.tool_version;
  j["dataset"] = {{"hash_fnv1a64", m.dataset_hash}, {"path", m.dataset_path}};
  if (!m.dataset_paths.empty()) {
    j["dataset"]["paths"] = m.dataset_paths;
    j["dataset"]["hash_covers"] = kDatasetHashCovers;
  }
  j["position_unit"] = m.position_unit;
  j["command_unit"] = m.command_unit;
  j["controller"] = {{"kp", m.controller.kp},
                     {"ki", m.controller.ki},
                     {"kd", m.controller.kd},
                     {"derivative_on",
                      m.controller.derivative_on == DerivativeOn::kError ? "error" : "measurement"},
                     {"v_limit", num(m.controller.v_limit)}};
  if (m.has_inertia_model) {
    const InertiaModel& im = m.linear.inertia;
    j["inertia_model"] = {
        {"equation", "I = I_base + I1 cos^2 g1 + I2 cos^2 psi + I3 cos g1 cos psi, psi = pi - g1 - g2 - gamma_offs (eq. 6)"},
        {"I_base", im.i_base}, {"I1", im.i1}, {"I2", im.i2}, {"I3", im.i3},
        {"gamma_offs_rad", im.gamma_offs_rad}, {"C0_bar", m.linear.c0_bar},
        {"standard_errors", {{"I_base", num(m.linear_se[0])}, {"I1", num(m.linear_se[1])},
                             {"I2", num(m.linear_se[2])}, {"I3", num(m.linear_se[3])},
                             {"gamma_offs_rad", num(m.linear_se[4])}, {"C0_bar", num(m.linear_se[5])}}}};
  } else {
    j["inertia_model"] = nullptr;
  }
  json poses = json::array();
  for (const auto& p : m.poses) {
    poses.push_back({{"gamma1_deg", p.gamma1_deg ? json(*p.gamma1_deg) : json(nullptr)},
                     {"gamma2_deg", p.gamma2_deg ? json(*p.gamma2_deg) : json(nullptr)},
                     {"C_linear", p.c_linear},
                     {"beta_tilde_linear", p.beta_tilde_linear}});
  }
  j["poses"] = poses;
  if (m.has_alpha_model) {
    const AlphaModel& a = m.alpha;
    json bp = json::array(), c = json::array(), cse = json::array();
    for (std::size_t k = 0; k < a.n_breakpoints; ++k) {
      bp.push_back(a.alpha[k]);
      c.push_back(a.c_n1[k]);
      cse.push_back(num(m.c_n1_se[k]));
    }
    j["alpha_model"] = {{"breakpoints", bp},
                        {"C_n1", c},
                        {"C_n1_se", cse},
                        {"beta_alpha", {a.beta_alpha[0], a.beta_alpha[1]}},
                        {"beta_n1", {a.beta_n1[0], a.beta_n1[1]}},
                        {"beta_n1_se", {num(m.beta_n1_se[0]), num(m.beta_n1_se[1])}}};
  } else {
    j["alpha_model"] = nullptr;
  }
  j["effects"] = format_effects(m.effects);
  j["simulation"] = {{"loop_period_s", m.loop_period_s}};
  j["notes"] = m.notes;
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

ModelFile parse_model_file(const std::string& text, const std::string& file) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {  // parse_error, and out_of_range for numbers like 1e999
    throw Error(std::string("malformed JSON: ") + e.what(), file);
  }
  if (!j.is_object()) throw Error("expected a JSON object", file);
  if (!j.contains("schema") || !j["schema"].is_string()) throw Error("missing key", file, 0, "schema");
  if (j["schema"].get<std::string>() != kModelSchema) {
    throw Error("expected \"" + std::string(kModelSchema) + "\", found " + j["schema"].dump(), file, 0,
                "schema");
  }
  ModelFile m;
  m.tool_version = j.value("tool_version", "");
  if (j.contains("dataset") && j["dataset"].is_object()) {
    m.dataset_hash = j["dataset"].value("hash_fnv1a64", "");
    m.dataset_path = j["dataset"].value("path", "");
    if (j["dataset"].contains("paths")) {
      const json& paths = j["dataset"]["paths"];
      if (!paths.is_array()) throw Error("expected an array of folder names", file, 0, "dataset.paths");
      for (const json& p : paths) {
        if (!p.is_string()) throw Error("expected a folder name (a string)", file, 0, "dataset.paths");
        m.dataset_paths.push_back(p.get<std::string>());
      }
    }
  }
  m.position_unit = j.value("position_unit", "rad");
  m.command_unit = j.value("command_unit", "V");
  if (!j.contains("controller") || !j["controller"].is_object()) throw Error("missing key", file, 0, "controller");
  const json& c = j["controller"];
  m.controller.kp = get_num(c, "kp", file, "controller.");
  // kp = 0 (with ki = kd = 0) is an open-loop model: a dataset without a controller, driven by
  // its recorded command (kUnstatedController); a negative or non-finite gain is not physical.
  if (!(m.controller.kp >= 0.0)) {
    throw Error("expected the P gain of the identification runs, >= 0 [V/rad] (0: open loop), found " +
                    common::shortest(m.controller.kp),
                file, 0, "controller.kp");
  }
  m.controller.ki = get_num(c, "ki", file, "controller.");
  m.controller.kd = get_num(c, "kd", file, "controller.");
  const double vl = get_num(c, "v_limit", file, "controller.", true);
  if (std::isfinite(vl) && !(vl > 0.0)) {
    throw Error("expected null (no limit) or a command limit > 0, found " + common::shortest(vl),
                file, 0, "controller.v_limit");
  }
  m.controller.v_limit = std::isfinite(vl) ? vl : std::numeric_limits<double>::infinity();
  const std::string d = c.value("derivative_on", "error");
  if (d != "error" && d != "measurement") throw Error("expected error or measurement", file, 0, "controller.derivative_on");
  m.controller.derivative_on = d == "error" ? DerivativeOn::kError : DerivativeOn::kMeasurement;
  if (j.contains("inertia_model") && !j["inertia_model"].is_null()) {
    const json& im = j["inertia_model"];
    m.has_inertia_model = true;
    m.linear.inertia.i_base = get_num(im, "I_base", file, "inertia_model.");
    m.linear.inertia.i1 = get_num(im, "I1", file, "inertia_model.");
    m.linear.inertia.i2 = get_num(im, "I2", file, "inertia_model.");
    m.linear.inertia.i3 = get_num(im, "I3", file, "inertia_model.");
    m.linear.inertia.gamma_offs_rad = get_num(im, "gamma_offs_rad", file, "inertia_model.");
    m.linear.c0_bar = get_num(im, "C0_bar", file, "inertia_model.");
    if (!(m.linear.c0_bar > 0.0)) throw Error("expected C0_bar > 0", file, 0, "inertia_model.C0_bar");
    m.linear_se.fill(kNaN);
    if (im.contains("standard_errors") && im["standard_errors"].is_object()) {
      const json& se = im["standard_errors"];
      const char* names[6] = {"I_base", "I1", "I2", "I3", "gamma_offs_rad", "C0_bar"};
      for (int k = 0; k < 6; ++k) {
        m.linear_se[static_cast<std::size_t>(k)] =
            get_num(se, names[k], file, "inertia_model.standard_errors.", true);
      }
    }
  }
  if (j.contains("poses") && j["poses"].is_array()) {
    std::size_t k = 0;
    for (const json& p : j["poses"]) {
      const std::string path = "poses[" + std::to_string(k++) + "].";
      PoseLinearModel pl;
      const double g1 = get_num(p, "gamma1_deg", file, path, true);
      const double g2 = get_num(p, "gamma2_deg", file, path, true);
      if (std::isfinite(g1)) pl.gamma1_deg = g1;
      if (std::isfinite(g2)) pl.gamma2_deg = g2;
      pl.c_linear = get_num(p, "C_linear", file, path);
      pl.beta_tilde_linear = get_num(p, "beta_tilde_linear", file, path);
      m.poses.push_back(pl);
    }
  }
  if (j.contains("alpha_model") && !j["alpha_model"].is_null()) {
    const json& a = j["alpha_model"];
    if (!a.contains("breakpoints") || !a["breakpoints"].is_array()) {
      throw Error("expected an array", file, 0, "alpha_model.breakpoints");
    }
    const std::size_t n = a["breakpoints"].size();
    if (n < 2 || n > kMaxBreakpoints) {
      throw Error("expected 2 to " + std::to_string(kMaxBreakpoints) + " breakpoints, found " +
                      std::to_string(n), file, 0, "alpha_model.breakpoints");
    }
    m.has_alpha_model = true;
    m.alpha.n_breakpoints = n;
    m.alpha.alpha = get_array<kMaxBreakpoints>(a, "breakpoints", n, file, "alpha_model.", false);
    m.alpha.c_n1 = get_array<kMaxBreakpoints>(a, "C_n1", n, file, "alpha_model.", false);
    m.alpha.beta_alpha = get_array<2>(a, "beta_alpha", 2, file, "alpha_model.", false);
    m.alpha.beta_n1 = get_array<2>(a, "beta_n1", 2, file, "alpha_model.", false);
    if (a.contains("C_n1_se")) m.c_n1_se = get_array<kMaxBreakpoints>(a, "C_n1_se", n, file, "alpha_model.", true);
    if (a.contains("beta_n1_se")) m.beta_n1_se = get_array<2>(a, "beta_n1_se", 2, file, "alpha_model.", true);
    if (!m.alpha.valid()) {
      throw Error("breakpoints must increase and C_n1, beta_n1 be positive", file, 0, "alpha_model");
    }
  }
  if (j.contains("effects")) m.effects = parse_effects(j["effects"], file);
  if (j.contains("simulation") && !j["simulation"].is_null()) {
    if (!j["simulation"].is_object()) throw Error("expected an object", file, 0, "simulation");
    m.loop_period_s = get_num(j["simulation"], "loop_period_s", file, "simulation.");
    if (m.loop_period_s < 0.0) {
      throw Error("expected loop_period_s >= 0 (0: continuous)", file, 0, "simulation.loop_period_s");
    }
  }
  if (j.contains("notes") && j["notes"].is_array()) {
    for (const json& n : j["notes"]) {
      if (n.is_string()) m.notes.push_back(n.get<std::string>());
    }
  }
  return m;
}

void write_model_file(const std::filesystem::path& path, const ModelFile& model) {
  common::write_file_atomically(path, format_model_file(model));
}

ModelFile read_model_file(const std::filesystem::path& path) {
  // A regular file of bounded size: /dev/zero, a FIFO or a folder is refused before reading.
  return parse_model_file(data_detail::read_file(path, kMaxModelFileBytes), path.string());
}

std::string hash_dataset(const std::filesystem::path& dir, const std::vector<std::string>& run_files) {
  return hash_dataset(std::vector<std::filesystem::path>{dir}, run_files);
}

std::string hash_dataset(const std::vector<std::filesystem::path>& dirs,
                         const std::vector<std::string>& run_files) {
  if (dirs.empty()) throw Error("expected at least one dataset folder to hash", {}, 0, "dataset");
  std::uint64_t h = 1469598103934665603ULL;
  auto feed = [&](const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    if (!in) throw Error("cannot open for hashing", p.string());
    char buf[65536];
    while (in) {
      in.read(buf, sizeof buf);
      const std::streamsize got = in.gcount();
      for (std::streamsize k = 0; k < got; ++k) {
        h ^= static_cast<unsigned char>(buf[k]);
        h *= 1099511628211ULL;
      }
    }
  };
  for (const auto& dir : dirs) feed(dir / "dataset.json");
  for (const auto& f : run_files) feed(dirs.front() / f);  // an absolute name stays as it is
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return hex;
}

}  // namespace alphainv
