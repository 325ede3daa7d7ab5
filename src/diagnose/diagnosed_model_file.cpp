/// \file diagnosed_model_file.cpp
/// A diagnosis folded into a model file (diagnosed_model_file.hpp).

#include "alphainv/diagnose/diagnosed_model_file.hpp"

#include <algorithm>
#include <string>
#include <vector>

#include "alphainv/simulate/model_simulation.hpp"

namespace alphainv {

void apply_diagnosis(ModelFile& m, const DiagnoseResult& r) {
  m.effects = r.effects;
  if (m.has_alpha_model && r.alpha) m.alpha = *r.alpha;  // re-identified with the effects
  if (m.has_alpha_model) {
    auto f = [](const std::vector<double>& v, std::size_t k) {
      return v.empty() ? 1.0 : v[std::min(k, v.size() - 1)];
    };
    for (std::size_t k = 0; k < m.alpha.n_breakpoints; ++k) m.alpha.c_n1[k] /= f(r.scales.c, k);
    m.alpha.beta_n1[0] /= f(r.scales.beta, 0);
    m.alpha.beta_n1[1] /= f(r.scales.beta, 1);
  }
  std::string names;
  for (EffectKind k : r.effects_named) names += (names.empty() ? "" : ", ") + std::string(effect_name(k));
  m.notes.push_back("omni_fit diagnose added: " + (names.empty() ? std::string("nothing (none)") : names) +
                    "; the α-model was " + (r.alpha ? std::string("re-identified from the sine runs with the effects in the plant input, then its ") : std::string("kept; its ")) + "C_n and β̃ were refitted with it by output error (factors applied to C_n1, β̃_n1)");
}

std::vector<DiagnoseRun> diagnose_runs(const Dataset& ds, const std::vector<RunData>& data,
                                       const ModelFile& model) {
  std::vector<DiagnoseRun> runs;
  for (std::size_t i = 0; i < ds.runs.size(); ++i) {
    DiagnoseRun r;
    r.data = &data[i];
    r.controller = ds.runs[i].controller;
    r.model = model_at(model, ds.runs[i].gamma1_deg, ds.runs[i].gamma2_deg, model.has_alpha_model);
    r.name = ds.runs[i].file;
    r.kind = ds.runs[i].kind;
    r.freq_hz = ds.runs[i].freq_hz;
    runs.push_back(r);
  }
  return runs;
}

}  // namespace alphainv
