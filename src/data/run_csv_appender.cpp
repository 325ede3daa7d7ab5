/// \file run_csv_appender.cpp
/// The run CSV written as it grows (include/alphainv/data/run_csv_appender.hpp).

#include "alphainv/data/run_csv_appender.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>

#include "alphainv/data/dataset.hpp"
#include "alphainv/error.hpp"
#include "common/atomic_file.hpp"
#include "common/format.hpp"

namespace alphainv {

RunCsvAppender::RunCsvAppender(const std::filesystem::path& csv,
                               std::vector<std::string> extra_columns)
    : path_(csv), extra_(std::move(extra_columns)) {
  // The header as format_run_csv writes it, and its checks of the column names: one zero row.
  RunData probe;
  probe.t = probe.r = probe.theta = probe.v = {0.0};
  for (const std::string& name : extra_) {
    if (!probe.extra_columns.emplace(name, std::vector<double>{0.0}).second) {
      throw Error("duplicate column", csv.string(), 0, name);
    }
  }
  const std::string text = format_run_csv(probe, csv.string());
  // format_run_csv orders the extra columns by name: keep that order for the rows too.
  extra_.clear();
  for (const auto& [name, values] : probe.extra_columns) extra_.push_back(name);
  for (const char* name : {"t", "r", "theta", "v"}) strict_.push_back(is_format_column(name));
  for (const std::string& name : extra_) strict_.push_back(is_format_column(name));
  non_finite_.assign(extra_.size(), 0);
  fd_ = ::open(csv.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    throw Error(std::string("cannot create the file: ") + std::strerror(errno), csv.string());
  }
  buffer_ = text.substr(0, text.find('\n') + 1);
  flush();
}

RunCsvAppender::~RunCsvAppender() {
  if (fd_ >= 0) ::close(fd_);
}

void RunCsvAppender::add_row(const double* values) {
  const std::size_t n = columns();
  const double t = values[0];
  if (!std::isfinite(t) || (rows_ > 0 && !(t > last_t_))) {
    throw Error("expected t finite and greater than the previous row's " +
                    common::shortest(last_t_) + ", found " + common::shortest(t),
                path_.string(), static_cast<long>(rows_ + 2), "t");
  }
  for (std::size_t j = 0; j < n; ++j) {
    if (strict_[j] && !std::isfinite(values[j])) {
      throw Error("expected a finite number, found " + common::shortest(values[j]),
                  path_.string(), static_cast<long>(rows_ + 2),
                  j < 4 ? std::string(j == 1 ? "r" : j == 2 ? "theta" : "v") : extra_[j - 4]);
    }
  }
  for (std::size_t j = 0; j < n; ++j) {
    if (j > 0) buffer_ += ',';
    if (std::isfinite(values[j])) {
      common::append_shortest(buffer_, values[j]);
    } else {
      buffer_ += "nan";
      ++non_finite_[j - 4];  // strict columns (t, r, theta, v among them) were checked above
    }
  }
  buffer_ += '\n';
  last_t_ = t;
  ++rows_;
  ++buffered_rows_;
}

void RunCsvAppender::write_all(const std::string& bytes) {
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t k = ::write(fd_, bytes.data() + written, bytes.size() - written);
    if (k < 0) {
      if (errno == EINTR) continue;
      throw Error(std::string("cannot append to the file: ") + std::strerror(errno),
                  path_.string());
    }
    written += static_cast<std::size_t>(k);
  }
}

void RunCsvAppender::flush() {
  if (fd_ < 0) throw Error("the file is closed", path_.string());
  write_all(buffer_);
  buffer_.clear();  // keeps its capacity: one flush period's rows
  if (::fdatasync(fd_) != 0) {
    throw Error(std::string("cannot flush the file to disk: ") + std::strerror(errno),
                path_.string());
  }
  if (!folder_synced_) {
    common::sync_folder_of(path_);
    folder_synced_ = true;
  }
  flushed_ += buffered_rows_;
  buffered_rows_ = 0;
}

void RunCsvAppender::close() {
  if (fd_ < 0) return;
  flush();
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) {
    throw Error(std::string("cannot close the file: ") + std::strerror(errno), path_.string());
  }
}

}  // namespace alphainv
