#include "alphainv/device/recording.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <nlohmann/json.hpp>
#include <system_error>

#include "alphainv/error.hpp"
#include "common/atomic_file.hpp"

namespace alphainv::device {

std::string RunResult::ended() const {
  if (fault != rt::Fault::kNone) return std::string("fault: ") + rt::to_string(fault);
  return stopped ? "stopped" : "completed";
}

std::string RunResult::brief_report() const {
  std::string out = "run " + std::to_string(run_id) + ": " + ended();
  if (dir.empty()) return out + ", not recorded";
  if (!recording_error.empty()) return out + "; recording not written: " + recording_error;
  out += ", " + std::to_string(rows) + " rows recorded to " + dir.string();
  if (dropped_rows > 0) {
    out += " (" + std::to_string(dropped_rows) + " rows dropped: the writer fell behind)";
  }
  if (!non_finite_note.empty()) {
    out += "; derived cells not finite, written as nan (readers ignore those columns, the "
           "measured ones are whole): " + non_finite_note;
  }
  return out;
}

std::string RunResult::full_report() const {
  return brief_report() + "\ntiming: " + timing.to_text() + "\n";
}

namespace {

namespace fs = std::filesystem;

/// The extra columns in the order RunCsvAppender writes them (by name).
const std::vector<std::string> kExtraColumns = {"C",      "alpha",      "beta_tilde",
                                                "gamma1", "gamma2",     "theta_pred",
                                                "torque_enable", "v_comp", "v_p"};  // by name, as the CSV orders them

}  // namespace

void prepare_recording_folder(const RunRecording& recording) {
  const fs::path& dir = recording.dir;
  const std::string name = dir.string();
  if (dir.empty()) throw Error("expected a folder to record into, found an empty path");
  if (!(recording.flush_period_s > 0.0) || recording.rows_per_file < 2) {
    throw Error("expected flush_period_s > 0 and rows_per_file >= 2", name);
  }
  std::error_code ec;
  const fs::file_status st = fs::status(dir, ec);
  if (st.type() != fs::file_type::not_found) {
    if (!fs::is_directory(st)) throw Error("expected a folder, found a file", name);
    if (!recording.force) {
      const bool has_index = fs::exists(dir / "dataset.json", ec);
      if (has_index || !fs::is_empty(dir, ec)) {
        throw Error(std::string(has_index ? "the folder already holds a dataset (dataset.json)"
                                          : "the folder is not empty") +
                        "; give a new folder, or --force to replace the dataset in it",
                    name);
      }
    }
  }
  fs::create_directories(dir, ec);
  if (ec) throw Error("cannot create the folder: " + ec.message(), name);
  // Prove it writable now rather than after the run: create, write, sync and remove a file.
  const fs::path probe = dir / (".write_probe." + std::to_string(::getpid()));
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    throw Error(std::string("cannot write into the folder: ") + std::strerror(errno), name);
  }
  const bool ok = ::write(fd, "\n", 1) == 1 && ::fsync(fd) == 0;
  const int err = errno;
  ::close(fd);
  ::unlink(probe.c_str());
  if (!ok) throw Error(std::string("cannot write into the folder: ") + std::strerror(err), name);
}

RunRecorder::RunRecorder(std::uint32_t run_id, std::optional<RunRecording> recording,
                         const rt::ControlLoopConfig& config, double kp)
    : run_id_(run_id), recording_(std::move(recording)), config_(config), kp_(kp) {
  part_non_finite_.assign(kExtraColumns.size(), 0);
}

RunRecorder::~RunRecorder() = default;

std::string RunRecorder::file_name(std::size_t part) const {
  return part == 0 ? "run.csv" : "run_" + std::to_string(part + 1) + ".csv";
}

long RunRecorder::rows_flushed() const noexcept {
  return rows_closed_ + (csv_ ? static_cast<long>(csv_->rows_flushed()) : 0);
}

void RunRecorder::add(const rt::TickRecord& record, double run_start_s) {
  if (ticks_ == 0) run_start_s_ = run_start_s;
  if (recording_ && write_error_.empty()) {
    try {
      write_row(record);
    } catch (const std::exception& e) {
      write_error_ = e.what();
      csv_.reset();  // the rows synced so far stay readable
    }
  }
  latency_.add(record.wake_latency_s);
  if (ticks_ > 0) period_jitter_.add(record.period_jitter_s);
  read_.add(record.read_s);
  write_.add(record.write_s);
  ++ticks_;
  misses_ += record.deadline_missed ? 1 : 0;
  skipped_ += record.deadlines_skipped;
}

void RunRecorder::start_file() {
  const std::size_t part = first_rows_.size() - 1;
  std::error_code ec;
  if (part == 0) fs::create_directories(recording_->dir, ec);  // prepare_recording_folder's job
  csv_ = std::make_unique<RunCsvAppender>(recording_->dir / file_name(part), kExtraColumns);
  if (csv_->extra_columns() != kExtraColumns) throw Error("the run file's columns changed order");
}

void RunRecorder::write_row(const rt::TickRecord& r) {
  const double t = r.t_s - run_start_s_;  // t = 0 where the waveform starts
  const bool new_file = !csv_ || csv_->rows() >= recording_->rows_per_file;
  if (new_file) {
    if (csv_) {
      csv_->close();
      for (std::size_t j = 0; j < kExtraColumns.size(); ++j) {
        part_non_finite_[j] += static_cast<long>(csv_->non_finite_cells(j));
      }
      rows_closed_ += static_cast<long>(csv_->rows());
    }
    first_rows_.push_back(r);
    start_file();
  }
  const double row[] = {t,           r.r_rad,       r.theta_rad,    r.command_v,
                        r.damping,   r.alpha,       r.beta_tilde,   r.gamma1_rad,
                        r.gamma2_rad, r.theta_pred_rad, r.enable ? 1.0 : 0.0,
                        r.comp_command_v, r.p_command_v};
  csv_->add_row(row);
  ++rows_;
  if (new_file) {
    // The file's first row on disk, then the index naming it: dataset.json never names a file
    // without rows.
    csv_->flush();
    last_flush_t_s_ = t;
    write_index("interrupted", nullptr);
  } else if (t - last_flush_t_s_ >= recording_->flush_period_s) {
    csv_->flush();
    last_flush_t_s_ = t;
  }
}

Dataset RunRecorder::dataset(const RunResult& result, const rt::ControlLoopConfig& config,
                             double kp) const {
  const RunRecording recording = recording_.value_or(RunRecording{});
  Dataset ds;
  ds.joint = "yaw";
  ds.sample_rate_hz = 1.0 / config.period_s;
  ds.controller.kp = kp;
  ds.controller.v_limit = config.safety.max_command_v;
  RunInfo info;
  switch (recording.wave.kind) {
    case rt::WaveKind::kSine:
    case rt::WaveKind::kSquare:
      info.kind = recording.wave.kind == rt::WaveKind::kSine ? "sine" : "square";
      info.freq_hz = recording.wave.freq_hz;
      info.amplitude_rad = recording.wave.amplitude_rad;
      break;
    case rt::WaveKind::kStep:
      info.kind = "step";
      info.amplitude_rad = recording.wave.amplitude_rad;
      break;
    case rt::WaveKind::kHold:
      info.kind = "other";
      break;
  }
  info.controller = ds.controller;
  for (std::size_t part = 0; part < std::max<std::size_t>(first_rows_.size(), 1); ++part) {
    RunInfo p = info;
    p.file = file_name(part);
    if (part < first_rows_.size()) {
      p.gamma1_deg = rad_to_deg(first_rows_[part].gamma1_rad);
      p.gamma2_deg = rad_to_deg(first_rows_[part].gamma2_rad);
    }
    if (part > 0) {
      // A continuation: a step or hold is no longer one from its start.
      if (p.kind != "sine" && p.kind != "square") {
        p.kind = "other";
        p.amplitude_rad.reset();
      }
      p.extra_json = nlohmann::json({{"continues", file_name(part - 1)}}).dump();
    }
    ds.runs.push_back(p);
  }
  nlohmann::json extra = {
      {"source", "omni_ctl"},
      {"command_line", recording.command_line},
      {"device", recording.device},
      {"model", recording.model_source},
      {"ended", result.ended()},
      {"rows", result.rows},
      {"dropped_rows", result.dropped_rows},
      {"max_slew_v_per_s", config.safety.max_slew_v_per_s},
      {"compensation", rt::to_string(config.compensation.mode)},
      {"columns",
       {{"theta_pred",
         "the model's prediction of this row's theta made one tick earlier "
         "(eq. (37) held over a tick); equal to theta when none was possible"},
        {"alpha", "streaming alpha-hat of the command history, eq. (33) [V^2/s^2]"},
        {"C", "C(alpha, I) [1/s], eqs. (38)-(40)"},
        {"beta_tilde", "beta~(alpha, I) [rad/s^2/V], eqs. (41)-(42)"},
        {"v_p", "the P law kp (r - theta) [V]"},
        {"v_comp", "the model-based compensation added to v_p before the clamp [V] "
                   "(omni_ctl --compensate; 0 without)"}}},
      {"timing", timing_json<nlohmann::json>(result.timing)}};
  ds.extra_json = extra.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return ds;
}

void RunRecorder::write_index(const std::string& ended, const RunResult* result) const {
  const RunResult none;
  Dataset ds = dataset(result != nullptr ? *result : none, config_, kp_);
  nlohmann::json extra = nlohmann::json::parse(ds.extra_json);
  if (result == nullptr) {  // written when the recording starts: what a kill leaves
    extra.erase("rows");
    extra.erase("dropped_rows");
    extra.erase("timing");
    extra["ended"] = ended;
    extra["interrupted"] =
        "written when the recording started and rewritten when it ends: a dataset still "
        "saying \"interrupted\" was cut short (a kill, a crash, a power cut); its run files "
        "hold every row up to the last flush, at most flush_period_s before the end";
    extra["flush_period_s"] = recording_->flush_period_s;
  } else if (!result->recording_error.empty()) {
    extra["recording_error"] = result->recording_error;
  }
  if (result != nullptr && !result->non_finite_note.empty()) {
    extra["non_finite_cells"] = result->non_finite_note;
  }
  ds.extra_json = extra.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  common::write_file_atomically(recording_->dir / "dataset.json", format_dataset_index(ds));
}

RunResult RunRecorder::finish(const RunEnd& end, const rt::ControlLoopConfig& config,
                              double kp) {
  RunResult result;
  result.run_id = run_id_;
  result.fault = end.fault;
  result.stopped = end.stopped;
  result.dropped_rows = end.dropped_rows;
  result.timing.ticks = ticks_;
  result.timing.deadline_misses = misses_;
  result.timing.skipped_ticks = skipped_;
  result.timing.period_s = config.period_s;
  result.timing.latency = latency_.summary();
  result.timing.period_jitter = period_jitter_.summary();
  result.timing.read = read_.summary();
  result.timing.write = write_.summary();
  if (!recording_) return result;

  result.dir = recording_->dir;
  config_ = config;
  kp_ = kp;
  if (csv_ && write_error_.empty()) {
    try {
      csv_->close();
    } catch (const std::exception& e) {
      write_error_ = e.what();
    }
  }
  result.rows = rows_flushed();
  std::vector<long> non_finite = part_non_finite_;
  for (std::size_t j = 0; csv_ && j < kExtraColumns.size(); ++j) {
    non_finite[j] += static_cast<long>(csv_->non_finite_cells(j));
  }
  for (std::size_t j = 0; j < kExtraColumns.size(); ++j) {
    if (non_finite[j] == 0) continue;
    if (!result.non_finite_note.empty()) result.non_finite_note += ", ";
    result.non_finite_note += kExtraColumns[j] + ": " + std::to_string(non_finite[j]);
  }
  if (!write_error_.empty()) {
    result.recording_error = write_error_ + " (" + std::to_string(result.rows) +
                             " rows were synced to disk before it)";
  }
  std::error_code ec;
  if (rows_ < 2) {
    // Nothing worth a dataset: remove what the first row created.
    for (std::size_t part = 0; part < first_rows_.size(); ++part) {
      fs::remove(recording_->dir / file_name(part), ec);
    }
    fs::remove(recording_->dir / "dataset.json", ec);
    result.rows = 0;
    if (result.recording_error.empty()) {
      result.recording_error =
          Error("fewer than 2 ticks were recorded", recording_->dir.string()).what();
    }
    return result;
  }
  try {
    write_index(result.ended(), &result);
  } catch (const std::exception& e) {
    if (!result.recording_error.empty()) result.recording_error += "; ";
    result.recording_error += e.what();
  }
  return result;
}

}  // namespace alphainv::device
