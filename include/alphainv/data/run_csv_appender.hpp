#pragma once
/// \file data/run_csv_appender.hpp
/// A run CSV of `alphainv-dataset/1` written while it grows (docs/dataset-format.md, "Files
/// written as they grow"): add_row() formats a row into a buffer, flush() appends the buffer to
/// the file and fdatasync's it. After a crash, a kill or a power cut the file holds its header and
/// every row up to the last flush; its last line may be cut short when the process died inside a
/// write, which readers drop when dataset.json says `"ended": "interrupted"`.
///
/// Memory is bounded by the rows between two flushes, whatever the file's length. Not real-time
/// safe (allocates when the buffer grows, blocks on the disk): call it off the 1 kHz tick.

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace alphainv {

class RunCsvAppender {
 public:
  /// Creates `csv` (a file already there is replaced) and writes and syncs the header
  /// `t,r,theta,v,<extra_columns…>`. Throws alphainv::Error (file: `csv`) when it cannot be
  /// created or a column name is one the format refuses (empty, t/r/theta/v, `,` `"` CR LF).
  RunCsvAppender(const std::filesystem::path& csv, std::vector<std::string> extra_columns);
  ~RunCsvAppender();  ///< closes the file; rows not flushed are lost (call close())
  RunCsvAppender(const RunCsvAppender&) = delete;
  RunCsvAppender& operator=(const RunCsvAppender&) = delete;

  /// Adds one row: `values` holds t, r, theta, v, then one value per extra column (columns()
  /// values). t [s] must be finite and greater than the previous row's; r, theta, v and the
  /// format's known columns (gamma1, gamma2, disturbance_v, torque_enable) finite. A non-finite
  /// value of any other column (a derived one, e.g. a prediction that overflowed) is written as
  /// `nan`, which readers ignore that column for, keeping the rest of the row (counted by
  /// non_finite_cells()). Throws alphainv::Error naming the file, row and column otherwise.
  void add_row(const double* values);
  /// Appends the rows added since the last flush and fdatasync's the file (the first flush also
  /// fsyncs the folder, so the file's name is durable). Throws alphainv::Error on a write error.
  void flush();
  /// flush() and closes the file. Throws alphainv::Error on a write error.
  void close();

  /// Number of values add_row() takes: 4 + the extra columns.
  std::size_t columns() const noexcept { return 4 + extra_.size(); }
  std::size_t rows() const noexcept { return rows_; }           ///< rows added
  std::size_t rows_flushed() const noexcept { return flushed_; }  ///< rows on disk
  /// Cells written as `nan` in extra column `j` (0-based among the extra columns).
  std::size_t non_finite_cells(std::size_t j) const { return non_finite_.at(j); }
  const std::vector<std::string>& extra_columns() const noexcept { return extra_; }
  const std::filesystem::path& path() const noexcept { return path_; }

 private:
  void write_all(const std::string& bytes);

  std::filesystem::path path_;
  std::vector<std::string> extra_;
  std::vector<bool> strict_;  ///< per column: must be finite
  std::vector<std::size_t> non_finite_;
  std::string buffer_;
  std::size_t rows_ = 0, flushed_ = 0, buffered_rows_ = 0;
  double last_t_ = 0.0;
  int fd_ = -1;
  bool folder_synced_ = false;
};

}  // namespace alphainv
