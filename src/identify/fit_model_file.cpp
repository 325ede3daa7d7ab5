/// \file fit_model_file.cpp
/// model.json contents of a dataset fit (fit_model_file.hpp).

#include "alphainv/identify/fit_model_file.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace alphainv {

ModelFile fit_model_file(const Dataset& ds, const DatasetFit& fit,
                         const std::vector<std::filesystem::path>& dataset_dirs) {
  ModelFile model;
  model.tool_version = "alphainv 0.1.0";
  const std::vector<std::filesystem::path> dirs =
      dataset_dirs.empty() ? std::vector<std::filesystem::path>{ds.dir} : dataset_dirs;
  if (!dirs.front().empty()) {  // an in-memory dataset (never read from a folder) has neither
    std::vector<std::string> files;
    for (const auto& r : ds.runs) files.push_back(r.file);
    model.dataset_hash = hash_dataset(dirs, files);
    model.dataset_path = std::filesystem::absolute(dirs.front()).string();
    for (const auto& d : dirs) model.dataset_paths.push_back(std::filesystem::absolute(d).string());
  }
  model.position_unit = ds.position_unit;
  model.command_unit = ds.command_unit;
  model.controller = ds.runs.front().controller;
  model.has_inertia_model = fit.has_inertia_model;
  if (fit.has_inertia_model) {
    model.linear = fit.inertia.model;
    for (std::size_t k = 0; k < 6; ++k) model.linear_se[k] = fit.inertia.standard_errors[k];
  }
  for (const auto& p : fit.poses) {
    if (!p.linear.valid) continue;
    model.poses.push_back({p.gamma1_deg, p.gamma2_deg, p.linear.c_linear, p.linear.beta_tilde_linear});
  }
  model.has_alpha_model = fit.alpha.ok;
  if (fit.alpha.ok) {
    model.alpha = fit.alpha.model;
    model.c_n1_se = fit.alpha.c_n1_se;
    model.beta_n1_se = fit.alpha.beta_n1_se;
  }
  model.effects = fit.effects;  // the known effects the model was fitted with
  model.loop_period_s = fit.simulation.loop_period_s;  // the simulation the model was identified with
  model.notes = fit.notes;
  return model;
}

}  // namespace alphainv
