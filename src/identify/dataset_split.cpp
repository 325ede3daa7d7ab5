#include "alphainv/identify/dataset_split.hpp"

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <utility>

#include "alphainv/error.hpp"

namespace alphainv {

namespace {

/// The dataset's fields without runs.
DatasetWithRuns empty_like(const Dataset& ds) {
  DatasetWithRuns out;
  out.dataset = ds;
  out.dataset.runs.clear();
  return out;
}

}  // namespace

DatasetWithRuns combine_datasets(const std::vector<DatasetWithRuns>& parts) {
  if (parts.empty()) throw Error("expected at least one dataset", {}, 0, "runs");
  DatasetWithRuns out = empty_like(parts.front().dataset);
  for (const DatasetWithRuns& p : parts) {
    const Dataset& ds = p.dataset;
    const std::string where = ds.dir.string() + " against " + parts.front().dataset.dir.string();
    if (ds.position_unit != out.dataset.position_unit) {
      throw Error("expected the same position unit in every dataset, got " + ds.position_unit +
                      " and " + out.dataset.position_unit + " (" + where + ")",
                  ds.dir.string(), 0, "position_unit");
    }
    if (ds.command_unit != out.dataset.command_unit) {
      throw Error("expected the same command unit in every dataset, got " + ds.command_unit +
                      " and " + out.dataset.command_unit + " (" + where + ")",
                  ds.dir.string(), 0, "command_unit");
    }
    if (ds.sample_rate_hz != out.dataset.sample_rate_hz) out.dataset.sample_rate_hz.reset();
    for (std::size_t i = 0; i < ds.runs.size(); ++i) {
      RunInfo r = ds.runs[i];
      if (parts.size() > 1) r.file = std::filesystem::absolute(ds.dir / r.file).string();
      out.dataset.runs.push_back(std::move(r));
      out.data.push_back(i < p.data.size() ? p.data[i] : RunData{});
    }
  }
  return out;
}

HoldoutSplit holdout_every_kth_run_per_pose(const DatasetWithRuns& all, std::size_t k) {
  if (k < 2) {
    throw Error("expected K >= 2 (every K-th run per pose held out), got " + std::to_string(k), {},
                0, "holdout");
  }
  HoldoutSplit split{empty_like(all.dataset), empty_like(all.dataset)};
  std::map<std::pair<std::optional<double>, std::optional<double>>, std::size_t> seen;
  for (std::size_t i = 0; i < all.dataset.runs.size(); ++i) {
    const RunInfo& r = all.dataset.runs[i];
    const std::size_t n = ++seen[{r.gamma1_deg, r.gamma2_deg}];
    DatasetWithRuns& to = n % k == 0 ? split.held_out : split.fit;
    to.dataset.runs.push_back(r);
    to.data.push_back(i < all.data.size() ? all.data[i] : RunData{});
  }
  if (split.held_out.dataset.runs.empty()) {
    throw Error("no pose has " + std::to_string(k) + " runs: nothing would be held out", {}, 0,
                "holdout");
  }
  if (split.fit.dataset.runs.empty()) {
    throw Error("every run would be held out", {}, 0, "holdout");
  }
  return split;
}

}  // namespace alphainv
