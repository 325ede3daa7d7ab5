#pragma once
/// \file diagnosed_model_file.hpp
/// A diagnosis folded into a model file: what `omni_fit diagnose` writes as model.json and the
/// Python module's `diagnose(...).model` holds. Set-up code, not real-time.

#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/data/model_file.hpp"
#include "alphainv/diagnose/diagnose.hpp"

namespace alphainv {

/// Sets `model`'s effects to the diagnosed ones; when it has an α-model, replaces it by the one
/// re-identified with the effects (DiagnoseResult::alpha, when given) and divides its C_n1 and
/// β̃_n1 by the fitted coefficient factors (ModelScales: C_n = 1/(C_n1·I), eq. (40), and
/// β̃_n = 1/(β̃_n1·I), eq. (42), are multiplied by them); adds a note saying what was added.
void apply_diagnosis(ModelFile& model, const DiagnoseResult& result);

/// The runs of `dataset` to diagnose `model` on (what `omni_fit diagnose --model` does): every run
/// under its own controller with the model at its pose (model_at(), the α-model when the model
/// has one). Throws alphainv::Error (from model_at) when the model has no model at a run's pose.
std::vector<DiagnoseRun> diagnose_runs(const Dataset& dataset, const std::vector<RunData>& data,
                                       const ModelFile& model);

}  // namespace alphainv
