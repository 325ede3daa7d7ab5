#include "alphainv/device/recording.hpp"

#include <nlohmann/json.hpp>

#include "alphainv/error.hpp"

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
  return out;
}

std::string RunResult::full_report() const {
  return brief_report() + "\ntiming: " + timing.to_text() + "\n";
}

RunRecorder::RunRecorder(std::uint32_t run_id, std::optional<RunRecording> recording)
    : run_id_(run_id), recording_(std::move(recording)) {
  if (recording_) rows_.reserve(1 << 16);
}

void RunRecorder::add(const rt::TickRecord& record, double run_start_s) {
  if (ticks_ == 0) run_start_s_ = run_start_s;
  if (recording_) rows_.push_back(record);
  latency_.add(record.wake_latency_s);
  if (ticks_ > 0) period_jitter_.add(record.period_jitter_s);
  read_.add(record.read_s);
  write_.add(record.write_s);
  ++ticks_;
  misses_ += record.deadline_missed ? 1 : 0;
  skipped_ += record.deadlines_skipped;
}

RunData RunRecorder::run_data() const {
  RunData data;
  const std::size_t n = rows_.size();
  const char* extra_names[] = {"gamma1",     "gamma2",     "alpha",        "C",
                               "beta_tilde", "theta_pred", "torque_enable", "v_p", "v_comp"};
  for (const char* name : extra_names) data.extra_columns[name].reserve(n);
  data.t.reserve(n);
  const double t0 = run_start_s_;  // t = 0 where the waveform starts
  for (const rt::TickRecord& r : rows_) {
    data.t.push_back(r.t_s - t0);
    data.r.push_back(r.r_rad);
    data.theta.push_back(r.theta_rad);
    data.v.push_back(r.command_v);
    data.extra_columns["gamma1"].push_back(r.gamma1_rad);
    data.extra_columns["gamma2"].push_back(r.gamma2_rad);
    data.extra_columns["alpha"].push_back(r.alpha);
    data.extra_columns["C"].push_back(r.damping);
    data.extra_columns["beta_tilde"].push_back(r.beta_tilde);
    data.extra_columns["theta_pred"].push_back(r.theta_pred_rad);
    data.extra_columns["torque_enable"].push_back(r.enable ? 1.0 : 0.0);
    data.extra_columns["v_p"].push_back(r.p_command_v);
    data.extra_columns["v_comp"].push_back(r.comp_command_v);
  }
  return data;
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
  info.file = "run.csv";
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
  if (!rows_.empty()) {
    info.gamma1_deg = rad_to_deg(rows_.front().gamma1_rad);
    info.gamma2_deg = rad_to_deg(rows_.front().gamma2_rad);
  }
  ds.runs.push_back(info);
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
  ds.extra_json = extra.dump();
  return ds;
}

RunResult RunRecorder::finish(const RunEnd& end, const rt::ControlLoopConfig& config,
                              double kp) const {
  RunResult result;
  result.run_id = run_id_;
  result.fault = end.fault;
  result.stopped = end.stopped;
  result.rows = static_cast<long>(rows_.size());
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
  try {
    if (rows_.size() < 2) throw Error("fewer than 2 ticks were recorded", recording_->dir.string());
    write_dataset(recording_->dir, dataset(result, config, kp), {run_data()});
  } catch (const std::exception& e) {
    result.recording_error = e.what();
  }
  return result;
}

}  // namespace alphainv::device
