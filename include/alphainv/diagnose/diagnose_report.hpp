#pragma once
/// \file diagnose_report.hpp
/// A diagnosis in words: the report.md of `omni_fit diagnose` (without its figures, which the app
/// draws and appends) and an effect's parameters as text. The one-line and multi-line summaries
/// are DiagnoseResult::brief_report() and full_report() (diagnose.hpp). Offline; not real-time.

#include <string>
#include <vector>

#include "alphainv/diagnose/diagnose.hpp"
#include "alphainv/model/effects.hpp"

namespace alphainv {

/// The parameters of effect `kind` in `e` with their units, e.g. "coulomb_v = 0.006866 command
/// unit" ("%.4g", joined by ", "); "–" for an effect without parameters (`none`).
std::string effect_parameters_text(const Effects& e, EffectKind kind);

/// The report (Markdown) of `result` on `runs` (the runs given to diagnose(), for their names):
/// where the model was wrong, the candidates of every round (score, folds, RMS after, parameters,
/// note; the `none` the winner had to beat at its breakpoints), the gap before and after per run,
/// and where the model is wrong after. `dataset` and `model_source` are named in its first lines.
std::string diagnose_report_markdown(const DiagnoseResult& result,
                                     const std::vector<DiagnoseRun>& runs,
                                     const std::string& dataset, const std::string& model_source);

/// The report's section on the external_disturbance stage (Markdown; empty when not tried): what
/// was located, the intervals (run, from, to, level), the pointer to a recorded `disturbance_v`
/// column and to disturbance.csv.
std::string disturbance_markdown(const DisturbanceFinding& finding);

/// The located series d̂ as CSV, "run,t,disturbance_v" and one row per sample of every run with
/// intervals (`runs`: the runs given to diagnose(), for their names and times).
std::string disturbance_csv(const DisturbanceFinding& finding, const std::vector<DiagnoseRun>& runs);

}  // namespace alphainv
