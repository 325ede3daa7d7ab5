#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace omni_fit {

/// Options of `omni_fit sweep`.
struct SweepCommandOptions {
  std::vector<std::uint64_t> seeds{1, 2};  ///< seeds of the generated datasets
  std::vector<std::string> effects;        ///< catalogue names to generate; empty: all and none
  bool quick = false;      ///< one magnitude, one noise level
  bool vary = false;       ///< draw magnitude factors and the effects' other parameters from the seed
  bool require = false;    ///< exit 1 unless every case is named right (and cut ≥ 30 %)
  bool json = false;
  bool no_discover = false;  ///< no discovered term after the named effects (the verdict judges them alone)
  unsigned threads = 0;
  std::string out_file;    ///< -o: the confusion matrix as Markdown
};

CLI::App* add_sweep_subcommand(CLI::App& app, SweepCommandOptions& options);

/// `omni_fit sweep`: generates datasets with one hidden effect each (and effect-free ones) with
/// the virtual Omni, diagnoses each, prints the confusion matrix. Exit 0, or 1 with --require
/// when a case is wrong.
int run_sweep(const SweepCommandOptions& options);

}  // namespace omni_fit
