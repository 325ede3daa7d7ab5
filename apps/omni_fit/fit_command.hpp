#pragma once
#include <string>

namespace omni_fit {

struct FitCommandOptions {
  std::string dataset_dir;
  std::string out_dir;
  bool json = false;
  bool quiet = false;
  bool no_plots = false;  ///< skip the report's figures (no data, scripts or PNGs)
  unsigned threads = 0;
  std::size_t n_breakpoints = 4;
};

/// `omni_fit fit`: returns the process exit code (0 ok, 2 bad input, 3 fit failure).
int run_fit(const FitCommandOptions& options);

}  // namespace omni_fit
