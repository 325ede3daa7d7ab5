#pragma once
/// \file fit_model_file.hpp
/// The model.json contents (alphainv-model/1, model_file.hpp) of a dataset fit: what `omni_fit fit`
/// writes and the Python module's `fit(...).model` holds. Set-up code, not real-time.

#include "alphainv/data/dataset.hpp"
#include "alphainv/data/model_file.hpp"
#include "alphainv/identify/fit_pipeline.hpp"

namespace alphainv {

/// The model file of `fit`, the fit of `dataset`: the inertia model (6) and C̄0 (24)-(26) with
/// their standard errors, the per-pose linear models (22), the α-model (38)-(42) with its
/// standard errors, the known effects and the simulation mode the fit used, its notes, and the
/// dataset's hash, path, units and first run's controller. A dataset whose `dir` is empty (made
/// in memory, never read from a folder) leaves the hash and the path empty. Throws
/// alphainv::Error when the dataset's files cannot be hashed (hash_dataset()).
/// `dataset_dirs`: the folders a combined dataset (combine_datasets()) was read from, all of them
/// hashed and listed (ModelFile::dataset_paths); empty: dataset.dir alone.
ModelFile fit_model_file(const Dataset& dataset, const DatasetFit& fit,
                         const std::vector<std::filesystem::path>& dataset_dirs = {});

}  // namespace alphainv
