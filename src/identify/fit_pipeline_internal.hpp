#pragma once
// Internal to alphainv::identify: what the stages of fit_dataset() (fit_stages.hpp) share and the
// API does not offer.

#include <cstddef>
#include <functional>
#include <mutex>
#include <string_view>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/identify/fit_pipeline.hpp"

namespace alphainv::detail {

/// FitPipelineOptions::progress, serialised by a mutex: stage 8's workers call it from their
/// threads. Does nothing when the options have no progress function.
class ProgressReporter {
 public:
  explicit ProgressReporter(const FitPipelineOptions& options) : progress_(options.progress) {}
  void operator()(std::string_view stage, std::size_t done, std::size_t total) {
    if (!progress_) return;
    const std::lock_guard<std::mutex> lock(mutex_);
    progress_(stage, done, total);
  }

 private:
  const std::function<void(std::string_view, std::size_t, std::size_t)>& progress_;
  std::mutex mutex_;
};

}  // namespace alphainv::detail
