#pragma once
/// \file dataset_split.hpp
/// Datasets for fitting on one part and validating on another (validation.hpp): several recordings
/// of one joint combined into one dataset, and every K-th run per pose held out. Set-up code:
/// allocates, throws alphainv::Error naming the field.

#include <cstddef>
#include <vector>

#include "alphainv/data/dataset.hpp"

namespace alphainv {

/// A dataset with its runs' data (`data[i]` of `dataset.runs[i]`).
struct DatasetWithRuns {
  Dataset dataset;
  std::vector<RunData> data;
};

/// The runs of every part in one dataset, in order: the first part's folder, units, sample rate
/// and extra JSON; each run's file made absolute (its own folder's), its controller the one in
/// force where it was recorded. Throws alphainv::Error (field "position_unit" or "command_unit",
/// naming both folders) when the parts' units differ, or ("runs") when there is no part. The
/// sample rate is kept only when every part states the same.
DatasetWithRuns combine_datasets(const std::vector<DatasetWithRuns>& parts);

/// Every k-th run of each pose (runs with the same gamma1_deg, gamma2_deg, in dataset order; the
/// k-th, 2k-th, …) moved to `held_out`, the others kept in `fit`, both with the dataset's
/// fields. Throws alphainv::Error (field "holdout") when k < 2, or when no run would be held out
/// or none left to fit.
struct HoldoutSplit {
  DatasetWithRuns fit;       ///< the runs to fit on
  DatasetWithRuns held_out;  ///< the runs to validate on
};
HoldoutSplit holdout_every_kth_run_per_pose(const DatasetWithRuns& all, std::size_t k);

}  // namespace alphainv
