#pragma once
/// \file model_file.hpp
/// `model.json`, the fitted model as omni_fit writes it and the library, omni_ctl and
/// `omni_fit simulate` load it. Versioned schema "alphainv-model/1". Not real-time.

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "alphainv/model/controller.hpp"
#include "alphainv/model/damping_model.hpp"
#include "alphainv/model/effects.hpp"
#include "alphainv/model/inertia_model.hpp"

namespace alphainv {

/// The schema this library reads and writes.
inline constexpr const char* kModelSchema = "alphainv-model/1";

/// A pose's own global linear model (used when there is no inertia model).
struct PoseLinearModel {
  std::optional<double> gamma1_deg, gamma2_deg;  ///< the pose, when known
  double c_linear = 0.0;                         ///< [1/s]
  double beta_tilde_linear = 0.0;                ///< [rad/s² per command unit]
};

/// Everything in model.json.
struct ModelFile {
  std::string tool_version;      ///< the alphainv version that wrote it
  /// FNV-1a 64, hex, of the dataset.json of every folder in dataset_paths (in order), then of
  /// every run file (hash_dataset()); model.json states this as "dataset"."hash_covers"
  std::string dataset_hash;
  std::string dataset_path;      ///< where the (first) dataset was read from (informational)
  /// Every dataset folder the model was fitted on (`omni_fit fit DIR1 DIR2 …`), the first one
  /// dataset_path; model.json's "dataset"."paths". Empty: only dataset_path (older files).
  std::vector<std::string> dataset_paths;
  std::string position_unit = "rad";
  std::string command_unit = "V";
  Controller controller;         ///< the controller of the identification runs
  bool has_inertia_model = false;
  LinearModel linear;            ///< inertia model (6) and C̄0 (24)-(26), when has_inertia_model
  std::array<double, 6> linear_se{};  ///< SE of I_base, I1, I2, I3, γ_offs [rad], C̄0 (NaN: unknown)
  std::vector<PoseLinearModel> poses; ///< per-pose global linear models (22)
  bool has_alpha_model = false;
  AlphaModel alpha;              ///< α-invariant model (38)-(42)
  std::array<double, kMaxBreakpoints> c_n1_se{};  ///< SE of C_n1
  std::array<double, 2> beta_n1_se{};             ///< SE of β̃_n1
  /// Effects beyond the α-model (effects.hpp) that `omni_fit diagnose` added; all off by default.
  /// JSON: "effects": [{"effect": "<catalogue name>", "parameters": {"<name>": x, …}}, …], the
  /// active effects in catalogue order with the parameters effect_parameters() lists (and
  /// coulomb_smoothing_rad_s with coulomb_friction). Absent in older files: all off.
  Effects effects;
  /// The simulation the model was identified with [s]: > 0 the digital loop at this tick period
  /// (SimulationOptions::loop_period_s), 0 the continuous law (43). JSON: "simulation":
  /// {"loop_period_s": x}; absent in older files: 0.
  double loop_period_s = 0.0;
  std::vector<std::string> notes;                 ///< what the fit could not do, choices made
};

/// Writes model.json atomically and durably (a temporary file in the same folder, fsync'ed, renamed
/// over `path`, the folder fsync'ed). Throws alphainv::Error on I/O, and
/// (before writing anything) on effects or loop_period_s that read_model_file would refuse.
void write_model_file(const std::filesystem::path& path, const ModelFile& model);
/// Largest model.json read_model_file() reads [bytes] (a fitted model is a few kB).
inline constexpr std::uint64_t kMaxModelFileBytes = std::uint64_t{16} << 20;
/// Reads model.json, a regular file of at most kMaxModelFileBytes (a FIFO, a device such as
/// /dev/zero, a folder: a clear error, no hang); throws alphainv::Error naming the file and the
/// key on anything malformed or physically impossible (controller.kp <= 0, controller.v_limit
/// <= 0, a coefficient that is not a finite number).
ModelFile read_model_file(const std::filesystem::path& path);
/// The JSON text of a model (what write_model_file writes).
std::string format_model_file(const ModelFile& model);
/// Parses model JSON text; `name_for_errors` is the file name errors give.
ModelFile parse_model_file(const std::string& json, const std::string& name_for_errors);

/// FNV-1a 64-bit hash of dataset.json and every run file of the dataset at `dir`, as 16 hex digits.
std::string hash_dataset(const std::filesystem::path& dir, const std::vector<std::string>& run_files);
/// The same over several folders fitted together: the dataset.json of every folder in `dirs`, in
/// order, then every run file (a relative name is taken in dirs.front(); combine_datasets() makes
/// the names of several folders absolute). One folder: hash_dataset(dirs.front(), run_files).
/// Throws alphainv::Error naming a file that cannot be read, or ("dataset") when `dirs` is empty.
std::string hash_dataset(const std::vector<std::filesystem::path>& dirs,
                         const std::vector<std::string>& run_files);
/// What "dataset"."hash_covers" in model.json says the hash covers.
inline constexpr const char* kDatasetHashCovers =
    "FNV-1a 64 of the dataset.json of every folder in paths, in order, then of every run file "
    "they name, in order";

}  // namespace alphainv
