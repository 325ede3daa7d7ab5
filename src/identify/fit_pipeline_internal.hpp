#pragma once
// Internal to alphainv::identify: parts of fit_dataset() kept in their own files.

#include <cstddef>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/identify/fit_pipeline.hpp"

namespace alphainv::detail {

/// Whether run `d` switches the motor off somewhere (a `torque_enable` column with a 0): the
/// closed-loop model does not hold then (free fall).
bool has_torque_off(const RunData& d);

/// Time-domain identification (time_domain_fit.hpp) of every pose without a valid linear model,
/// and of the α-model when the sine runs gave none (single-pose datasets).
void add_time_domain_fit(const Dataset& dataset, const std::vector<RunData>& data,
                         const FitPipelineOptions& options, DatasetFit& fit);

}  // namespace alphainv::detail
