#pragma once
/// \file dataset.hpp
/// Reader and atomic writer of the dataset interchange format `alphainv-dataset/1`
/// (docs/dataset-format.md): a folder holding `dataset.json` and the run CSV files it names.
///
/// Every function here is set-up / I/O code: it allocates, and throws `alphainv::Error` naming the
/// file, the line (when there is one), the column or key, and what was expected versus found.
/// None of it is real-time safe.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "alphainv/model/controller.hpp"

namespace alphainv {

/// The value of the `format` key this library reads and writes.
inline constexpr std::string_view kDatasetFormat = "alphainv-dataset/1";

/// The law the reader starts from before the dataset's `controller` object and `kp` shorthand
/// apply: every gain 0 (kp = 0 means no P law is stated, which the fit skips), the derivative on
/// the error, no limit. A default-constructed Dataset or RunInfo holds it too.
inline constexpr Controller kUnstatedController{0.0};

/// One entry of the `runs` list of dataset.json.
struct RunInfo {
  std::string file;  ///< CSV path relative to the dataset folder, e.g. "runs/sine_1hz.csv"
  std::string kind;  ///< "sine", "square", "step", "chirp" or "other"
  std::optional<double> freq_hz;  ///< reference frequency [Hz]; required for sine and square
  std::optional<double>
      amplitude_rad;  ///< reference amplitude [position unit]; required for sine, square
  std::optional<double> gamma1_deg;  ///< measured pose of the other joint 1 [deg]
  std::optional<double> gamma2_deg;  ///< measured pose of the other joint 2 [deg]
  /// The law in force for this run: the dataset's controller (with its `kp` shorthand), then
  /// this run's `controller` object and `kp` shorthand applied on top.
  Controller controller = kUnstatedController;
  /// The whole run object as read, as JSON text, so keys this library does not know are kept.
  /// On writing, the fields above replace the keys they stand for. Empty: no extra keys.
  std::string extra_json;
};

/// The columns of one run CSV. All vectors have the same length, size().
struct RunData {
  std::vector<double> t;      ///< time [s], finite and strictly increasing
  std::vector<double> r;      ///< reference [position unit]
  std::vector<double> theta;  ///< measured position [position unit]
  std::vector<double> v;      ///< command sent by the controller [command unit]
  /// Every other numeric column by header name, e.g. "gamma1", "gamma2" [rad], "disturbance_v"
  /// [command unit], "torque_enable" [0/1], "v_comp" [command unit].
  std::map<std::string, std::vector<double>> extra_columns;
  /// Unknown columns that were not read because a cell was not a finite number (the format says
  /// unknown columns are ignored). Never written.
  std::vector<std::string> ignored_columns;

  /// Number of samples (rows).
  std::size_t size() const noexcept { return t.size(); }
  /// The column called `name` (t, r, theta, v or an extra column), or nullptr.
  const std::vector<double>* column(std::string_view name) const;
  /// Rows [begin, end) with every column (t, r, theta, v and each extra column: a window of the
  /// run keeps its known inputs, torque_enable, disturbance_v, v_comp, and its pose). Throws
  /// alphainv::Error (field "end") unless begin ≤ end ≤ size().
  RunData rows(std::size_t begin, std::size_t end) const;
};

/// The contents of dataset.json.
struct Dataset {
  std::filesystem::path dir;  ///< the dataset folder (set by the reader; ignored by the writer)
  std::string joint;          ///< free text: "yaw", "prismatic", "pendulum", ...; empty: absent
  std::string position_unit = "rad";     ///< "rad" or "m"
  std::string command_unit = "V";        ///< "V", "pwm", ...
  std::optional<double> sample_rate_hz;  ///< nominal sample rate [Hz]; the `t` column is the truth
  /// The dataset-wide controller (runs may override it).
  Controller controller = kUnstatedController;
  std::vector<RunInfo> runs;             ///< at least one, each naming a different file
  /// dataset.json's `ended` is "interrupted": its writer did not finish (a recording killed or
  /// crashed while it streamed, docs/dataset-format.md). read_run() then drops an incomplete last
  /// line of each run file. Set by the reader; the writer writes `ended` from extra_json.
  bool interrupted = false;
  /// The dataset.json object as read, without `runs`, as JSON text, so unknown keys (`source`, ...)
  /// are kept. On writing, the fields above replace the keys they stand for. Empty: none.
  std::string extra_json;
};

/// Size limits, checked before anything large is allocated.
struct ReadLimits {
  std::uint64_t max_csv_bytes = std::uint64_t{2} << 30;     ///< largest run CSV [bytes] (2 GiB)
  std::uint64_t max_index_bytes = std::uint64_t{64} << 20;  ///< largest dataset.json [bytes]
  std::size_t max_rows = 50'000'000;                        ///< most data rows in one CSV
  std::size_t max_columns = 1024;                           ///< most columns in one CSV
};

/// True for the columns the format names and readers read strictly (every cell a finite number):
/// t, r, theta, v, gamma1, gamma2, disturbance_v, torque_enable. Other columns are the writer's
/// own; a reader ignores one that holds a cell that is not a finite number.
bool is_format_column(std::string_view name);

// --- reading -------------------------------------------------------------------------------------

/// Reads `dir`/dataset.json (not the runs) and checks that every run file exists.
Dataset read_dataset_index(const std::filesystem::path& dir, const ReadLimits& limits = {});

/// Parses dataset.json text. Checks keys and types but not the file system (run files need not
/// exist). `dir` is stored in the result and used to name `dir`/dataset.json in errors.
Dataset parse_dataset_index(std::string_view json, const std::filesystem::path& dir);

/// Largest |r|, |theta|, |v| read_run() accepts: no joint position [rad or m] or command [V or
/// pwm counts] comes near it, and squares of such values (α, eq. (33)) stay finite.
inline constexpr double kMaxPhysicalMagnitude = 1e9;

/// Reads run `i` of `dataset` (the file `dataset.dir / dataset.runs[i].file`) and checks it for
/// sense: a run whose r, theta and v are all zero carries no information, and a value beyond
/// kMaxPhysicalMagnitude is not a measurement; both throw Error naming the file, line and
/// column. With `dataset.interrupted`, an incomplete last line (no line end) is dropped.
RunData read_run(const Dataset& dataset, std::size_t i, const ReadLimits& limits = {});

/// Reads one run CSV file.
RunData read_run_csv(const std::filesystem::path& csv, const ReadLimits& limits = {});

/// Parses run CSV text; `name_for_errors` is the file name errors give.
RunData parse_run_csv(std::string_view text, const std::string& name_for_errors,
                      const ReadLimits& limits = {});

// --- writing -------------------------------------------------------------------------------------

/// Run CSV text for `data` (header t,r,theta,v then the extra columns by name; numbers in the
/// shortest form that reads back bit-identical). Throws if `data` would not read back (ragged
/// columns, non-finite values, `t` not strictly increasing, bad column names).
/// `name_for_errors` is the file name errors give.
std::string format_run_csv(const RunData& data, const std::string& name_for_errors = "run");

/// dataset.json text for `dataset` (its `dir` is ignored). Throws if the result would not read
/// back with parse_dataset_index, naming the offending key.
std::string format_dataset_index(const Dataset& dataset);

/// Writes one run CSV atomically: to a temporary file in the same folder, flushed to disk, then
/// renamed over `csv`. Readers see the old file or the new one, never a part.
void write_run_csv(const std::filesystem::path& csv, const RunData& data);

/// Writes a whole dataset into `dir` (created if missing): every run to `dir`/runs[i].file, then
/// dataset.json last, each atomically, so the folder never holds a dataset.json whose runs are not
/// all complete. An existing dataset.json is removed first, so a failed rewrite leaves no index
/// rather than one pointing at a mix of old and new runs. Everything is validated before the
/// first byte is written. `data[i]` is the data of `dataset.runs[i]`.
void write_dataset(const std::filesystem::path& dir, const Dataset& dataset,
                   const std::vector<RunData>& data);

}  // namespace alphainv
