// libFuzzer target for the alphainv-dataset/1 reader (include/alphainv/data/dataset.hpp).
//
// The first input byte chooses what the rest is fed to (byte % 4):
//   0  parse_run_csv                 the hand-written CSV reader
//   1  parse_dataset_index           dataset.json parsing and validation
//   2  CSV round trip                whatever parses must format and parse back bit-identical
//   3  dataset.json round trip       whatever parses must format and parse back equal
// alphainv::Error is the expected outcome for bad input; any other exception, a sanitizer report
// or a round-trip mismatch is a bug. Build and run: see tests/fuzz/CMakeLists.txt.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include "alphainv/data/dataset.hpp"
#include "alphainv/error.hpp"

namespace {

using alphainv::Dataset;
using alphainv::RunData;
using alphainv::RunInfo;

[[noreturn]] void mismatch(const char* what) {
  std::fprintf(stderr, "round-trip mismatch: %s\n", what);
  std::abort();
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

void csv_round_trip(std::string_view text) {
  RunData first;
  try {
    first = alphainv::parse_run_csv(text, "fuzz.csv");
  } catch (const alphainv::Error&) {
    return;  // bad input, rejected as it should be
  }
  // What the reader accepts, the writer must accept, and reading it back must give the same bits.
  const std::string written = alphainv::format_run_csv(first, "fuzz.csv");
  const RunData second = alphainv::parse_run_csv(written, "fuzz.csv");
  if (!same_bits(first.t, second.t) || !same_bits(first.r, second.r) ||
      !same_bits(first.theta, second.theta) || !same_bits(first.v, second.v)) {
    mismatch("required columns");
  }
  if (first.extra_columns.size() != second.extra_columns.size()) mismatch("extra column count");
  for (const auto& [name, values] : first.extra_columns) {
    const auto it = second.extra_columns.find(name);
    if (it == second.extra_columns.end() || !same_bits(values, it->second))
      mismatch("extra column");
  }
  if (!second.ignored_columns.empty()) mismatch("ignored columns written");
}

bool same_run(const RunInfo& a, const RunInfo& b) {
  return a.file == b.file && a.kind == b.kind && a.freq_hz == b.freq_hz &&
         a.amplitude_rad == b.amplitude_rad && a.gamma1_deg == b.gamma1_deg &&
         a.gamma2_deg == b.gamma2_deg && a.controller == b.controller;
}

void index_round_trip(std::string_view text) {
  Dataset first;
  try {
    first = alphainv::parse_dataset_index(text, "fuzz");
  } catch (const alphainv::Error&) {
    return;
  }
  const std::string written = alphainv::format_dataset_index(first);
  const Dataset second = alphainv::parse_dataset_index(written, "fuzz");
  if (first.joint != second.joint || first.position_unit != second.position_unit ||
      first.command_unit != second.command_unit || first.sample_rate_hz != second.sample_rate_hz ||
      first.controller != second.controller || first.runs.size() != second.runs.size()) {
    mismatch("dataset fields");
  }
  for (std::size_t i = 0; i < first.runs.size(); ++i) {
    if (!same_run(first.runs[i], second.runs[i])) mismatch("run fields");
  }
  // The writer's own output is a fixed point.
  if (alphainv::format_dataset_index(second) != written) mismatch("second rewrite differs");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  switch (data[0] % 4) {
    case 0:
      try {
        (void)alphainv::parse_run_csv(text, "fuzz.csv");
      } catch (const alphainv::Error&) {
      }
      break;
    case 1:
      try {
        (void)alphainv::parse_dataset_index(text, "fuzz");
      } catch (const alphainv::Error&) {
      }
      break;
    case 2:
      csv_round_trip(text);
      break;
    default:
      index_round_trip(text);
      break;
  }
  return 0;
}
