#pragma once
// Test helper: the real datasets in ../shared/datasets (beside the clone, as CI has them).
// Without them a test that reads one is skipped with the path it looked for, unless
// ALPHAINV_REQUIRE_SHARED=1 (set by .ci/run): then the test runs and fails on the missing file,
// so CI never passes by skipping the real data.
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

namespace alphainv::test {

/// ../shared/datasets as the build saw it (ALPHAINV_SHARED_DIR).
inline std::filesystem::path shared_datasets() {
  return std::filesystem::path(ALPHAINV_SHARED_DIR) / "datasets";
}

/// Why a test reading shared_datasets()/name must be skipped; nullopt when it can run (the
/// dataset is there, or ALPHAINV_REQUIRE_SHARED=1 requires it).
inline std::optional<std::string> shared_dataset_missing(const std::string& name) {
  const std::filesystem::path p = shared_datasets() / name / "dataset.json";
  std::error_code ec;
  if (std::filesystem::exists(p, ec)) return std::nullopt;
  const char* require = std::getenv("ALPHAINV_REQUIRE_SHARED");
  if (require != nullptr && std::string(require) == "1") return std::nullopt;
  return "the real dataset " + p.string() +
         " is not here (../shared beside the clone); ALPHAINV_REQUIRE_SHARED=1 makes this a failure";
}

}  // namespace alphainv::test

/// Skips the test when the shared dataset `name` is missing (shared_dataset_missing()).
#define ALPHAINV_SKIP_WITHOUT_SHARED_DATASET(name)                                       \
  if (const auto alphainv_missing_ = ::alphainv::test::shared_dataset_missing(name)) \
  GTEST_SKIP() << *alphainv_missing_
