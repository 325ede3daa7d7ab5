#pragma once
/// \file fit_report.hpp
/// report.md of a dataset fit, as `omni_fit fit` writes it: what the data could and could not
/// support (the fit's notes), the local linear points (19), (20), (36), the global linear model
/// per pose (22), the inertia model (6), (27)-(29), the α-invariant model (38)-(42) and the
/// validation (Table 8 and Table 11 style), in Markdown. The library writes it; the app adds its
/// figures and writes the file. Not real-time safe (allocates); never throws.

#include <string>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/identify/fit_pipeline.hpp"

namespace alphainv {

/// What report.md says beyond the dataset and its fit.
struct FitReportInfo {
  std::string dataset_hash;  ///< hash of the runs (ModelFile::dataset_hash, hash_dataset())
  /// The folders fitted together (`omni_fit fit DIR1 DIR2 …`); more than one: all named, and the
  /// hash said to cover each one's dataset.json. Empty: the dataset's `dir`.
  std::vector<std::string> dataset_dirs;
  /// Where the known effects came from, e.g. "from `diag.json`" or "`--effect …`"; shown when the
  /// fit has active effects.
  std::string effects_source;
  /// Markdown appended as is after the validation tables (omni_fit's figures); empty: none.
  std::string appendix_markdown;
};

/// The report of `fit`, the fit of `dataset` (its `dir`, run files and units are named).
std::string fit_report_markdown(const Dataset& dataset, const DatasetFit& fit,
                                const FitReportInfo& info = {});

/// A number as the reports print it: printf `format` (e.g. "%.4g", "%.2f"), or "–" when `x` is not
/// finite (an empty table cell).
std::string report_number(double x, const char* format = "%.4g");

}  // namespace alphainv
