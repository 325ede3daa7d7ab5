// Tests of include/alphainv/data/dataset.hpp: the alphainv-dataset/1 reader and atomic writer.
// One test per class of bad input (each checks the error names the file and the line, column or
// key), bit-exact round trips, the atomic writer, and the two real datasets in ../shared/datasets.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/error.hpp"
#include "support/error_of.hpp"
#include "support/shared_datasets.hpp"

namespace alphainv {
namespace {

namespace fs = std::filesystem;

const fs::path kSharedDatasets = alphainv::test::shared_datasets();
const char* const kGoodCsv = "t,r,theta,v\n0,0,0,0\n0.001,0.1,0.01,1.5\n";

void write_text(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

using test::error_of;

void expect_contains(const std::string& text, const std::vector<std::string>& parts) {
  for (const auto& part : parts) {
    EXPECT_NE(text.find(part), std::string::npos) << "'" << part << "' not in: " << text;
  }
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

void expect_same_data(const RunData& a, const RunData& b) {
  EXPECT_TRUE(same_bits(a.t, b.t));
  EXPECT_TRUE(same_bits(a.r, b.r));
  EXPECT_TRUE(same_bits(a.theta, b.theta));
  EXPECT_TRUE(same_bits(a.v, b.v));
  ASSERT_EQ(a.extra_columns.size(), b.extra_columns.size());
  for (const auto& [name, values] : a.extra_columns) {
    ASSERT_EQ(b.extra_columns.count(name), 1u) << name;
    EXPECT_TRUE(same_bits(values, b.extra_columns.at(name))) << name;
  }
}

void expect_same_run_info(const RunInfo& a, const RunInfo& b) {
  EXPECT_EQ(a.file, b.file);
  EXPECT_EQ(a.kind, b.kind);
  EXPECT_EQ(a.freq_hz, b.freq_hz);
  EXPECT_EQ(a.amplitude_rad, b.amplitude_rad);
  EXPECT_EQ(a.gamma1_deg, b.gamma1_deg);
  EXPECT_EQ(a.gamma2_deg, b.gamma2_deg);
  EXPECT_EQ(a.controller, b.controller);
}

/// A fresh temporary folder per test, removed afterwards.
class DatasetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("alphainv_test_dataset_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    for (const auto& entry : fs::recursive_directory_iterator(dir_, ec)) {
      fs::permissions(entry.path(), fs::perms::owner_all, fs::perm_options::add, ec);
    }
    fs::remove_all(dir_, ec);
  }

  /// Writes `csv` to <dir>/bad.csv and returns the error reading it throws.
  Error csv_error(const std::string& csv, const ReadLimits& limits = {}) {
    write_text(dir_ / "bad.csv", csv);
    return error_of([&] { read_run_csv(dir_ / "bad.csv", limits); });
  }

  /// Checks an error from bad.csv names the file, the line and (if given) the column.
  static void expect_csv_error(const Error& e, long line, const std::string& column,
                               const std::vector<std::string>& parts) {
    EXPECT_NE(e.file().find("bad.csv"), std::string::npos) << e.what();
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_EQ(e.field(), column) << e.what();
    std::vector<std::string> all = parts;
    all.push_back("bad.csv" + (line > 0 ? ":" + std::to_string(line) : std::string()));
    if (!column.empty()) all.push_back("'" + column + "'");
    expect_contains(e.what(), all);
  }

  /// Writes `json` as <dir>/dataset.json (and a valid runs/a.csv) and returns the reader's error.
  Error index_error(const std::string& json) {
    write_text(dir_ / "runs" / "a.csv", kGoodCsv);
    write_text(dir_ / "dataset.json", json);
    return error_of([&] { read_dataset_index(dir_); });
  }

  /// Checks an error from dataset.json names the file and the key.
  static void expect_index_error(const Error& e, const std::string& key,
                                 const std::vector<std::string>& parts) {
    EXPECT_NE(e.file().find("dataset.json"), std::string::npos) << e.what();
    EXPECT_EQ(e.field(), key) << e.what();
    std::vector<std::string> all = parts;
    all.push_back("dataset.json");
    if (!key.empty()) all.push_back("'" + key + "'");
    expect_contains(e.what(), all);
  }

  /// dataset.json text with the given run objects (comma-separated JSON) and extra top-level keys.
  static std::string index_json(const std::string& runs, const std::string& extra = "") {
    return "{\"format\": \"alphainv-dataset/1\", " + extra + "\"runs\": [" + runs + "]}";
  }

  fs::path dir_;
};

// --- run CSV: accepted variants
// ---------------------------------------------------------------------

TEST_F(DatasetTest, CsvReadsColumnsAndExtras) {
  write_text(dir_ / "ok.csv",
             "theta,t,v,r,torque_enable,note,weight\n"
             "1,0,2,3,1,first,0.5\n"
             "4,1,5,6,0,second,0.25\n");
  const RunData d = read_run_csv(dir_ / "ok.csv");
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d.t, (std::vector<double>{0, 1}));
  EXPECT_EQ(d.r, (std::vector<double>{3, 6}));
  EXPECT_EQ(d.theta, (std::vector<double>{1, 4}));
  EXPECT_EQ(d.v, (std::vector<double>{2, 5}));
  ASSERT_NE(d.column("torque_enable"), nullptr);
  EXPECT_EQ(*d.column("torque_enable"), (std::vector<double>{1, 0}));
  EXPECT_EQ(*d.column("weight"), (std::vector<double>{0.5, 0.25}));
  // Unknown non-numeric columns are ignored, as the format says, and listed.
  EXPECT_EQ(d.column("note"), nullptr);
  EXPECT_EQ(d.ignored_columns, (std::vector<std::string>{"note"}));
}

TEST_F(DatasetTest, CsvAcceptsCrlfBomSpacesAndLineEndVariants) {
  const RunData expected = parse_run_csv(kGoodCsv, "x");
  for (const std::string& text : {
           std::string("t,r,theta,v\r\n0,0,0,0\r\n0.001,0.1,0.01,1.5\r\n"),  // CRLF
           std::string("t,r,theta,v\n0,0,0,0\n0.001,0.1,0.01,1.5"),          // no final newline
           std::string("t,r,theta,v\n0,0,0,0\n0.001,0.1,0.01,1.5\n\n\r\n"),  // blank lines at EOF
           std::string("\xEF\xBB\xBFt,r,theta,v\n0,0,0,0\n0.001,0.1,0.01,1.5\n"),  // UTF-8 BOM
           std::string("t , r,theta,\tv\n0, 0 ,0,0\n1e-3,+.1,10e-3,15E-1\n"),  // spaces, notations
       }) {
    SCOPED_TRACE(text);
    const RunData d = parse_run_csv(text, "x");
    expect_same_data(d, expected);
  }
}

TEST_F(DatasetTest, CsvNumberSyntax) {
  for (const auto& [cell, value] :
       std::vector<std::pair<std::string, double>>{{"1", 1.0},
                                                   {"-1.5", -1.5},
                                                   {"+2", 2.0},
                                                   {".5", 0.5},
                                                   {"5.", 5.0},
                                                   {"1e3", 1000.0},
                                                   {"1E+3", 1000.0},
                                                   {"-2.5e-3", -2.5e-3},
                                                   {"0e-400", 0.0},
                                                   {"4.9e-324", 4.9e-324}}) {
    const RunData d = parse_run_csv("t,r,theta,v\n0,0,0," + cell + "\n", "x");
    EXPECT_EQ(d.v.at(0), value) << cell;
  }
}

// --- run CSV: one test per class of bad input
// --------------------------------------------------------

TEST_F(DatasetTest, CsvMissingFile) {
  const Error e = error_of([&] { read_run_csv(dir_ / "nope.csv"); });
  expect_contains(e.what(), {"nope.csv", "does not exist"});
}

TEST_F(DatasetTest, CsvEmptyFile) {
  expect_csv_error(csv_error(""), 1, "", {"empty file"});
  expect_csv_error(csv_error("\n \r\n\n"), 1, "", {"empty file"});
}

TEST_F(DatasetTest, CsvBlankHeader) {
  expect_csv_error(csv_error("\nt,r,theta,v\n0,0,0,0\n"), 1, "", {"header", "blank line"});
}

TEST_F(DatasetTest, CsvHeaderMissingRequiredColumn) {
  expect_csv_error(csv_error("t,r,v\n0,0,0\n"), 1, "theta", {"missing required column"});
  expect_csv_error(csv_error("time,r,theta,v\n0,0,0,0\n"), 1, "t", {"missing required column"});
}

TEST_F(DatasetTest, CsvDuplicateColumn) {
  expect_csv_error(csv_error("t,r,theta,v,r\n0,0,0,0,0\n"), 1, "r",
                   {"duplicate column", "columns 2 and 5"});
}

TEST_F(DatasetTest, CsvEmptyOrQuotedColumnName) {
  expect_csv_error(csv_error("t,r,,theta,v\n0,0,0,0,0\n"), 1, "", {"empty", "column 3"});
  expect_csv_error(csv_error("t,r,\"theta\",v\n0,0,0,0\n"), 1, "\"theta\"", {"quoted"});
}

TEST_F(DatasetTest, CsvRaggedRows) {
  expect_csv_error(csv_error("t,r,theta,v\n0,0,0,0\n1,0,0\n"), 3, "",
                   {"expected 4 cells", "found 3"});
  expect_csv_error(csv_error("t,r,theta,v\n0,0,0,0,9\n"), 2, "", {"expected 4 cells", "found 5"});
}

TEST_F(DatasetTest, CsvNonNumericCells) {
  for (const std::string cell :
       {"abc", "1.2.3", "0x10", "1e", "--1", "+-1", "1e+", ".", "1d3", "1 2", "\xff"}) {
    SCOPED_TRACE(cell);
    expect_csv_error(csv_error("t,r,theta,v\n0,0,0,0\n1,0," + cell + ",0\n"), 3, "theta",
                     {"expected a number", "column 3"});
  }
  expect_csv_error(csv_error("t,r,theta,v\n0,,0,0\n"), 2, "r", {"empty cell", "column 2"});
}

TEST_F(DatasetTest, CsvNonFiniteCells) {
  for (const std::string cell : {"nan", "NaN", "-nan", "inf", "-Inf", "infinity", "nan(0x1)"}) {
    SCOPED_TRACE(cell);
    expect_csv_error(csv_error("t,r,theta,v\n0,0,0," + cell + "\n"), 2, "v",
                     {"expected a finite number"});
  }
  // A known optional column is read as strictly as the required ones.
  expect_csv_error(csv_error("t,r,theta,v,gamma1\n0,0,0,0,nan\n"), 2, "gamma1",
                   {"expected a finite number"});
}

TEST_F(DatasetTest, CsvOutOfRangeNumber) {
  expect_csv_error(csv_error("t,r,theta,v\n0,1e400,0,0\n"), 2, "r", {"range of a double"});
  expect_csv_error(csv_error("t,r,theta,v\n0,1e-400,0,0\n"), 2, "r", {"range of a double"});
}

TEST_F(DatasetTest, CsvTimeNotStrictlyIncreasing) {
  expect_csv_error(csv_error("t,r,theta,v\n0,0,0,0\n1,0,0,0\n1,0,0,0\n"), 4, "t",
                   {"strictly increasing", "on line 3"});
  expect_csv_error(csv_error("t,r,theta,v\n0,0,0,0\n-1,0,0,0\n"), 3, "t", {"strictly increasing"});
}

TEST_F(DatasetTest, CsvBlankLineBetweenRows) {
  expect_csv_error(csv_error("t,r,theta,v\n0,0,0,0\n\n1,0,0,0\n"), 3, "", {"blank line"});
  expect_csv_error(csv_error("t,r,theta,v\r\n0,0,0,0\r\n  \r\n1,0,0,0\r\n"), 3, "", {"blank line"});
}

TEST_F(DatasetTest, CsvHeaderOnly) {
  expect_csv_error(csv_error("t,r,theta,v\n"), 2, "", {"at least one data row"});
}

TEST_F(DatasetTest, CsvStrayCarriageReturn) {
  expect_csv_error(csv_error("t,r,theta,v\r0,0,0,0\r"), 1, "", {"carriage return"});  // old Mac
  expect_csv_error(csv_error("t,r,theta,v\n0,0,0\r,0\n"), 2, "", {"carriage return"});
}

TEST_F(DatasetTest, CsvAbsurdSizesRefusedBeforeReading) {
  ReadLimits small;
  small.max_csv_bytes = 16;
  expect_csv_error(csv_error(kGoodCsv, small), 0, "", {"bytes; the limit is 16"});
  ReadLimits few_rows;
  few_rows.max_rows = 2;
  expect_csv_error(csv_error("t,r,theta,v\n0,0,0,0\n1,0,0,0\n2,0,0,0\n", few_rows), 0, "",
                   {"3 lines after the header; the limit is 2"});
  EXPECT_NO_THROW(parse_run_csv("t,r,theta,v\n0,0,0,0\n1,0,0,0\n\n", "x", few_rows));
  ReadLimits few_columns;
  few_columns.max_columns = 4;
  expect_csv_error(csv_error("t,r,theta,v,w\n0,0,0,0,0\n", few_columns), 1, "",
                   {"5 columns; the limit is 4"});
  // The default limits are the documented ones.
  EXPECT_EQ(ReadLimits{}.max_csv_bytes, std::uint64_t{2} << 30);
  EXPECT_EQ(ReadLimits{}.max_rows, 50'000'000u);
}

TEST_F(DatasetTest, CsvErrorsQuoteBinaryGarbageReadably) {
  const Error e =
      error_of([] { parse_run_csv(std::string("t,r,theta,v\n0,0,0,\x01\x02\n"), "x"); });
  expect_contains(e.what(), {"'\\x01\\x02'"});
}

// --- dataset.json: one test per class of bad input
// ---------------------------------------------------

TEST_F(DatasetTest, IndexMissing) {
  const Error e = error_of([&] { read_dataset_index(dir_); });
  expect_contains(e.what(), {"dataset.json", "does not exist"});
}

TEST_F(DatasetTest, IndexMalformedJsonReportsLine) {
  const Error e = index_error("{\n  \"format\": \"alphainv-dataset/1\",\n  \"runs\": [,]\n}\n");
  EXPECT_EQ(e.line(), 3) << e.what();
  expect_contains(e.what(), {"dataset.json:3", "malformed JSON", "column 12"});
  const Error empty = index_error("");
  EXPECT_EQ(empty.line(), 1) << empty.what();
  expect_contains(empty.what(), {"dataset.json:1", "malformed JSON"});
}

TEST_F(DatasetTest, IndexNotAnObject) {
  expect_index_error(index_error("[1, 2]"), "", {"expected a JSON object", "an array"});
}

TEST_F(DatasetTest, IndexMissingOrUnknownFormat) {
  expect_index_error(index_error(R"({"runs": [{"file": "runs/a.csv", "kind": "step"}]})"), "format",
                     {"missing required key", "alphainv-dataset/1"});
  expect_index_error(
      index_error(
          R"({"format": "alphainv-dataset/2", "runs": [{"file": "runs/a.csv", "kind": "step"}]})"),
      "format", {"unsupported format", "expected \"alphainv-dataset/1\"", "'alphainv-dataset/2'"});
  expect_index_error(index_error(R"({"format": 1, "runs": []})"), "format",
                     {"expected a string", "number"});
}

TEST_F(DatasetTest, IndexMissingOrEmptyRuns) {
  expect_index_error(index_error(R"({"format": "alphainv-dataset/1"})"), "runs",
                     {"missing required key"});
  expect_index_error(index_error(index_json("")), "runs", {"at least one run"});
  expect_index_error(index_error(R"({"format": "alphainv-dataset/1", "runs": {}})"), "runs",
                     {"expected a list", "an object"});
}

TEST_F(DatasetTest, IndexRunMissingFileOrKind) {
  expect_index_error(index_error(index_json(R"({"kind": "step"})")), "runs[0].file",
                     {"missing required key"});
  expect_index_error(
      index_error(index_json(R"({"file": "runs/a.csv", "kind": "step"}, {"file": "runs/a.csv"})")),
      "runs[1].kind", {"missing required key"});
  expect_index_error(index_error(index_json("3")), "runs[0]", {"expected an object", "number"});
}

TEST_F(DatasetTest, IndexUnknownKind) {
  expect_index_error(index_error(index_json(R"({"file": "runs/a.csv", "kind": "sinus"})")),
                     "runs[0].kind",
                     {"expected one of sine, square, step, chirp, other", "'sinus'"});
}

TEST_F(DatasetTest, IndexSineAndSquareNeedFrequencyAndAmplitude) {
  expect_index_error(
      index_error(index_json(R"({"file": "runs/a.csv", "kind": "sine", "amplitude_rad": 0.1})")),
      "runs[0].freq_hz", {"missing required key", "sine"});
  expect_index_error(
      index_error(index_json(R"({"file": "runs/a.csv", "kind": "square", "freq_hz": 1})")),
      "runs[0].amplitude_rad", {"missing required key", "square"});
  expect_index_error(
      index_error(index_json(
          R"({"file": "runs/a.csv", "kind": "sine", "freq_hz": 0, "amplitude_rad": 0.1})")),
      "runs[0].freq_hz", {"greater than 0"});
}

TEST_F(DatasetTest, IndexWrongTypes) {
  const std::string run = R"({"file": "runs/a.csv", "kind": "step"})";
  struct Case {
    std::string extra;
    std::string key;
    std::string expected;
  };
  for (const Case& c : std::vector<Case>{
           {R"("joint": 3, )", "joint", "expected a string"},
           {R"("sample_rate_hz": "1000", )", "sample_rate_hz", "expected a number"},
           {R"("sample_rate_hz": -1, )", "sample_rate_hz", "greater than 0"},
           {R"("controller": [], )", "controller", "expected an object"},
           {R"("controller": {"kp": "2"}, )", "controller.kp", "expected a number"},
           {R"("controller": {"kd": true}, )", "controller.kd", "expected a number"},
           {R"("controller": {"derivative_on": "rate"}, )", "controller.derivative_on",
            "\"error\" or \"measurement\""},
           {R"("controller": {"v_limit": "none"}, )", "controller.v_limit", "expected a number"},
           {R"("controller": {"v_limit": 0}, )", "controller.v_limit", "greater than 0"},
           {R"("kp": "x", )", "kp", "expected a number"},
           {R"("command_unit": "", )", "command_unit", "empty"},
       }) {
    SCOPED_TRACE(c.extra);
    expect_index_error(index_error(index_json(run, c.extra)), c.key, {c.expected});
  }
  expect_index_error(index_error(index_json(R"({"file": 7, "kind": "step"})")), "runs[0].file",
                     {"expected a string"});
  expect_index_error(
      index_error(index_json(R"({"file": "runs/a.csv", "kind": "step", "gamma1_deg": "90"})")),
      "runs[0].gamma1_deg", {"expected a number"});
  expect_index_error(
      index_error(index_json(
          R"({"file": "runs/a.csv", "kind": "step", "controller": {"kp": null, "ki": []}})")),
      "runs[0].controller.ki", {"expected a number", "an array"});
}

TEST_F(DatasetTest, IndexNumberOutOfRange) {
  const Error e =
      index_error("{\"format\": \"alphainv-dataset/1\",\n\"kp\": -1e400,\n\"runs\": []}");
  EXPECT_EQ(e.line(), 2) << e.what();
  expect_contains(e.what(), {"dataset.json:2", "range of a double", "1e400"});
}

TEST_F(DatasetTest, IndexBadPositionUnit) {
  expect_index_error(index_error(index_json(R"({"file": "runs/a.csv", "kind": "step"})",
                                            R"("position_unit": "deg", )")),
                     "position_unit", {"expected \"rad\" or \"m\"", "'deg'"});
}

TEST_F(DatasetTest, IndexRunFileDoesNotExist) {
  expect_index_error(index_error(index_json(R"({"file": "runs/a.csv", "kind": "step"},
                                               {"file": "runs/missing.csv", "kind": "step"})")),
                     "runs[1].file", {"does not exist", "missing.csv"});
  expect_index_error(index_error(index_json(R"({"file": "runs", "kind": "step"})")), "runs[0].file",
                     {"expected a regular file"});
}

TEST_F(DatasetTest, IndexRunFileOutsideFolder) {
  for (const std::string file : {"/etc/passwd", "../a.csv", "runs/../../a.csv", "", "runs/",
                                 "dataset.json", "./dataset.json"}) {
    SCOPED_TRACE(file);
    expect_index_error(index_error(index_json(R"({"file": ")" + file + R"(", "kind": "step"})")),
                       "runs[0].file", {"expected"});
  }
}

TEST_F(DatasetTest, IndexDuplicateKey) {
  expect_index_error(
      index_error(R"({"format": "alphainv-dataset/1", "controller": {"kp": 1, "kp": 2},
                                     "runs": [{"file": "runs/a.csv", "kind": "step"}]})"),
      "kp", {"duplicate key"});
}

TEST_F(DatasetTest, IndexTooDeeplyNested) {
  const std::string deep = std::string(200, '[') + std::string(200, ']');
  const Error e = index_error(
      index_json(R"({"file": "runs/a.csv", "kind": "step"})", "\"junk\": " + deep + ", "));
  expect_contains(e.what(), {"dataset.json", "nested"});
}

TEST_F(DatasetTest, IndexTooLarge) {
  write_text(dir_ / "runs" / "a.csv", kGoodCsv);
  write_text(dir_ / "dataset.json", index_json(R"({"file": "runs/a.csv", "kind": "step"})"));
  ReadLimits limits;
  limits.max_index_bytes = 10;
  const Error e = error_of([&] { read_dataset_index(dir_, limits); });
  expect_contains(e.what(), {"dataset.json", "the limit is 10 bytes"});
}

TEST_F(DatasetTest, IndexKpShorthandConflict) {
  expect_index_error(index_error(index_json(R"({"file": "runs/a.csv", "kind": "step"})",
                                            R"("kp": 2, "controller": {"kp": 3}, )")),
                     "kp", {"contradicts controller.kp"});
}

TEST_F(DatasetTest, ReadRunIndexOutOfRange) {
  write_text(dir_ / "runs" / "a.csv", kGoodCsv);
  write_text(dir_ / "dataset.json", index_json(R"({"file": "runs/a.csv", "kind": "step"})"));
  const Dataset ds = read_dataset_index(dir_);
  EXPECT_EQ(read_run(ds, 0).size(), 2u);
  const Error e = error_of([&] { read_run(ds, 1); });
  expect_contains(e.what(), {"dataset.json", "'runs'", "out of range"});
}

// --- dataset.json: accepted content
// ------------------------------------------------------------------

TEST_F(DatasetTest, IndexDefaultsShorthandAndControllerMerge) {
  for (const char* f : {"a.csv", "b.csv", "c.csv"}) write_text(dir_ / "runs" / f, kGoodCsv);
  write_text(dir_ / "dataset.json", R"({
    "format": "alphainv-dataset/1", "kp": 2.5, "source": "bench", "sample_rate_hz": null,
    "controller": {"kd": 0.1, "derivative_on": "measurement", "v_limit": 12, "note": "x"},
    "runs": [
    {"file": "runs/a.csv", "kind": "sine", "freq_hz": 0.5, "amplitude_rad": 0.2, "gamma1_deg": 90},
    {"file": "runs/b.csv", "kind": "step", "kp": 7, "controller": {"v_limit": null, "ki": 1}},
    {"file": "./runs/c.csv", "kind": "chirp", "trajectory": "up", "controller": {"kp": 4}}
    ]})");
  const Dataset ds = read_dataset_index(dir_);
  EXPECT_EQ(ds.dir, dir_);
  EXPECT_EQ(ds.joint, "");
  EXPECT_EQ(ds.position_unit, "rad");
  EXPECT_EQ(ds.command_unit, "V");
  EXPECT_FALSE(ds.sample_rate_hz.has_value());
  EXPECT_EQ(ds.controller.kp, 2.5);
  EXPECT_EQ(ds.controller.ki, 0.0);
  EXPECT_EQ(ds.controller.kd, 0.1);
  EXPECT_EQ(ds.controller.derivative_on, DerivativeOn::kMeasurement);
  EXPECT_EQ(ds.controller.v_limit, 12.0);
  expect_contains(ds.extra_json, {"\"source\":\"bench\""});
  EXPECT_EQ(ds.extra_json.find("\"runs\""), std::string::npos);
  ASSERT_EQ(ds.runs.size(), 3u);
  EXPECT_EQ(ds.runs[0].controller, ds.controller);
  EXPECT_EQ(ds.runs[0].freq_hz, 0.5);
  EXPECT_EQ(ds.runs[0].amplitude_rad, 0.2);
  EXPECT_EQ(ds.runs[0].gamma1_deg, 90.0);
  EXPECT_FALSE(ds.runs[0].gamma2_deg.has_value());
  EXPECT_EQ(ds.runs[1].controller.kp, 7.0);
  EXPECT_EQ(ds.runs[1].controller.ki, 1.0);
  EXPECT_EQ(ds.runs[1].controller.kd, 0.1);
  EXPECT_FALSE(ds.runs[1].controller.has_limit());
  EXPECT_EQ(ds.runs[2].controller.kp, 4.0);
  EXPECT_EQ(ds.runs[2].controller.v_limit, 12.0);
  expect_contains(ds.runs[2].extra_json, {"\"trajectory\":\"up\""});
}

TEST_F(DatasetTest, IndexWithoutControllerReadsAsUnstatedLaw) {
  write_text(dir_ / "runs" / "a.csv", kGoodCsv);
  write_text(dir_ / "dataset.json", index_json(R"({"file": "runs/a.csv", "kind": "step"})"));
  const Dataset ds = read_dataset_index(dir_);
  // kp = 0 (no P law stated: the fit skips such runs), not the simulator's default kp = 2.
  EXPECT_EQ(ds.controller, kUnstatedController);
  EXPECT_EQ(ds.controller.kp, 0.0);
  EXPECT_EQ(ds.controller.ki, 0.0);
  EXPECT_EQ(ds.controller.kd, 0.0);
  EXPECT_EQ(ds.controller.derivative_on, DerivativeOn::kError);
  EXPECT_FALSE(ds.controller.has_limit());
  EXPECT_EQ(ds.runs.at(0).controller, kUnstatedController);
  EXPECT_EQ(Dataset{}.controller, kUnstatedController);
  EXPECT_EQ(RunInfo{}.controller, kUnstatedController);
  EXPECT_NE(kUnstatedController, Controller{});  // Controller{} is the kp = 2 P law
}

// --- writer
// ------------------------------------------------------------------------------------------

/// `n` samples with random finite values of every magnitude (fixed seed), and extra columns.
RunData random_run(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  auto any_finite = [&] {
    while (true) {
      const std::uint64_t bits = rng();
      double x = 0.0;
      std::memcpy(&x, &bits, sizeof x);
      if (std::isfinite(x)) return x;
    }
  };
  std::uniform_real_distribution<double> step(1e-4, 2e-3);
  RunData d;
  double t = -1.0 / 3.0;
  for (std::size_t k = 0; k < n; ++k) {
    d.t.push_back(t);
    t += step(rng);
    d.r.push_back(std::sin(t) / 3.0);
    d.theta.push_back(any_finite());
    d.v.push_back(k % 7 == 0 ? -0.0 : any_finite());
    d.extra_columns["gamma1"].push_back(std::ldexp(any_finite(), -1000) / 7.0);  // subnormals
    d.extra_columns["torque_enable"].push_back(static_cast<double>(k % 2));
  }
  return d;
}

Dataset small_dataset() {
  Dataset ds;
  ds.joint = "yaw";
  ds.position_unit = "rad";
  ds.command_unit = "V";
  ds.sample_rate_hz = 1000.0 / 3.0;
  ds.controller.kp = 2.0 / 3.0;
  ds.controller.kd = 1e-300;
  ds.controller.derivative_on = DerivativeOn::kMeasurement;
  ds.controller.v_limit = 10.0;
  ds.extra_json = R"({"source": "unit test", "nested": {"a": [1, 2.5, null]}})";
  RunInfo sine;
  sine.file = "runs/sine.csv";
  sine.kind = "sine";
  sine.freq_hz = 0.1;
  sine.amplitude_rad = 0.7;
  sine.gamma1_deg = 90.0;
  sine.gamma2_deg = -45.5;
  sine.controller = ds.controller;
  sine.extra_json = R"({"trajectory": "s1", "kp": 99})";  // the stale kp is replaced by controller
  RunInfo step;
  step.file = "other/step run.csv";
  step.kind = "step";
  step.controller = ds.controller;
  step.controller.kp = 0.1;
  step.controller.v_limit = std::numeric_limits<double>::infinity();  // an explicit null override
  ds.runs = {sine, step};
  return ds;
}

TEST_F(DatasetTest, RoundTripIsBitIdentical) {
  const Dataset ds = small_dataset();
  const std::vector<RunData> data = {random_run(1000, 1), random_run(17, 2)};
  write_dataset(dir_ / "out", ds, data);

  const Dataset back = read_dataset_index(dir_ / "out");
  EXPECT_EQ(back.joint, ds.joint);
  EXPECT_EQ(back.position_unit, ds.position_unit);
  EXPECT_EQ(back.command_unit, ds.command_unit);
  EXPECT_EQ(back.sample_rate_hz, ds.sample_rate_hz);
  EXPECT_EQ(back.controller, ds.controller);
  expect_contains(back.extra_json, {"\"source\":\"unit test\"", "\"nested\":{\"a\":[1,2.5,null]}"});
  ASSERT_EQ(back.runs.size(), ds.runs.size());
  for (std::size_t i = 0; i < ds.runs.size(); ++i) {
    SCOPED_TRACE(i);
    expect_same_run_info(back.runs[i], ds.runs[i]);
    // Random bit patterns as theta and v: the CSV layer's property, beside read_run's checks
    // for sense (|theta| <= kMaxPhysicalMagnitude).
    expect_same_data(read_run_csv(back.dir / back.runs[i].file), data[i]);
  }
  expect_contains(back.runs[0].extra_json, {"\"trajectory\":\"s1\""});
  EXPECT_EQ(back.runs[0].extra_json.find("99"), std::string::npos);

  // Writing what was read gives the same files, byte for byte.
  std::vector<RunData> data_back = {read_run_csv(back.dir / back.runs[0].file),
                                    read_run_csv(back.dir / back.runs[1].file)};
  write_dataset(dir_ / "again", back, data_back);
  auto slurp = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  for (const std::string rel : {"dataset.json", "runs/sine.csv", "other/step run.csv"}) {
    EXPECT_EQ(slurp(dir_ / "out" / rel), slurp(dir_ / "again" / rel)) << rel;
  }
}

TEST_F(DatasetTest, RoundTripRealPendulumDataset) {
  ALPHAINV_SKIP_WITHOUT_SHARED_DATASET("xl330_pendulum");
  const Dataset ds = read_dataset_index(kSharedDatasets / "xl330_pendulum");
  std::vector<RunData> data;
  for (std::size_t i = 0; i < ds.runs.size(); ++i) data.push_back(read_run(ds, i));
  write_dataset(dir_ / "copy", ds, data);
  const Dataset back = read_dataset_index(dir_ / "copy");
  EXPECT_EQ(back.controller, ds.controller);
  expect_contains(back.extra_json, {"\"source\":\"Rhoban/bam"});
  ASSERT_EQ(back.runs.size(), ds.runs.size());
  for (std::size_t i = 0; i < ds.runs.size(); ++i) {
    expect_same_run_info(back.runs[i], ds.runs[i]);
    expect_contains(back.runs[i].extra_json,
                    {"\"trajectory\"", "\"servo_kp_register\"", "\"supply_v\":7.4"});
    expect_same_data(read_run(back, i), data[i]);
  }
  // A second rewrite changes nothing: the writer's layout is stable.
  write_dataset(dir_ / "copy2", back, data);
  auto slurp = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_EQ(slurp(dir_ / "copy" / "dataset.json"), slurp(dir_ / "copy2" / "dataset.json"));
}

TEST_F(DatasetTest, WriterSpellsNoLimitAsNull) {
  Dataset ds = small_dataset();
  ds.controller.v_limit = std::numeric_limits<double>::infinity();
  ds.runs[0].controller = ds.controller;
  ds.runs[1].controller = ds.controller;
  ds.runs[1].controller.v_limit = 3.5;  // a run's own limit: an override
  const std::string text = format_dataset_index(ds);
  expect_contains(text, {"\"v_limit\": null", "\"v_limit\": 3.5"});
  const Dataset back = parse_dataset_index(text, dir_);
  EXPECT_FALSE(back.controller.has_limit());
  EXPECT_FALSE(back.runs[0].controller.has_limit());
  EXPECT_EQ(back.runs[1].controller.v_limit, 3.5);
  ds.runs[1].controller.v_limit = -1.0;  // read back as invalid: the writer names the key
  const Error e = error_of([&] { format_dataset_index(ds); });
  EXPECT_EQ(e.field(), "runs[1].controller.v_limit") << e.what();
  expect_contains(e.what(), {"expected null or a number greater than 0, found -1"});
}

TEST_F(DatasetTest, WriterRejectsInvalidDataBeforeWritingAnything) {
  const Dataset ds = small_dataset();
  auto expect_rejected = [&](std::vector<RunData> data, const std::string& field,
                             const std::vector<std::string>& parts) {
    const Error e = error_of([&] { write_dataset(dir_ / "out", ds, data); });
    EXPECT_EQ(e.field(), field) << e.what();
    expect_contains(e.what(), parts);
    EXPECT_FALSE(fs::exists(dir_ / "out")) << "nothing may be written";
  };
  RunData ragged = random_run(5, 3);
  ragged.theta.pop_back();
  expect_rejected({random_run(5, 1), ragged}, "theta", {"step run.csv", "expected 5 values"});
  RunData nan = random_run(5, 3);
  nan.r[2] = std::numeric_limits<double>::quiet_NaN();
  expect_rejected({nan, random_run(5, 1)}, "r", {"sine.csv", "finite", "index 2"});
  RunData backwards = random_run(5, 3);
  backwards.t[3] = backwards.t[2];
  expect_rejected({backwards, random_run(5, 1)}, "t", {"strictly increasing", "index 3"});
  RunData bad_name = random_run(5, 3);
  bad_name.extra_columns["a,b"] = bad_name.t;
  expect_rejected({bad_name, random_run(5, 1)}, "", {"column name"});
  expect_rejected({random_run(5, 1)}, "runs", {"one RunData per run"});
  Dataset bad_kind = ds;
  bad_kind.runs[1].kind = "ramp";
  const Error e = error_of([&] {
    write_dataset(dir_ / "out", bad_kind, {random_run(5, 1), random_run(5, 2)});
  });
  EXPECT_EQ(e.field(), "runs[1].kind") << e.what();
  Dataset same_file = ds;
  same_file.runs[1].file = "runs/./sine.csv";
  const Error e2 = error_of([&] {
    write_dataset(dir_ / "out", same_file, {random_run(5, 1), random_run(5, 2)});
  });
  EXPECT_EQ(e2.field(), "runs[1].file") << e2.what();
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

/// Every file under `dir` whose name marks it as a writer's temporary file.
std::vector<std::string> temp_files(const fs::path& dir) {
  std::vector<std::string> found;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.path().filename().string().find(".tmp.") != std::string::npos) {
      found.push_back(entry.path().string());
    }
  }
  return found;
}

TEST_F(DatasetTest, AtomicWriterLeavesNoIndexWhenARunFails) {
  Dataset ds = small_dataset();
  const std::vector<RunData> data = {random_run(50, 1), random_run(50, 2)};
  const fs::path out = dir_ / "out";
  write_dataset(out, ds, data);  // a complete old dataset
  ASSERT_TRUE(fs::exists(out / "dataset.json"));
  // Block the second run: its folder "other" becomes a regular file (works even as root).
  fs::remove_all(out / "other");
  write_text(out / "other", "not a folder");
  const Error e = error_of([&] { write_dataset(out, ds, data); });
  expect_contains(e.what(), {"step run.csv"});
  EXPECT_FALSE(fs::exists(out / "dataset.json")) << "a failed write must leave no index";
  EXPECT_TRUE(fs::exists(out / "runs" / "sine.csv"));  // the first run is complete
  EXPECT_EQ(temp_files(out), std::vector<std::string>{});
}

TEST_F(DatasetTest, AtomicWriterUnwritableRunFolder) {
  if (::geteuid() == 0) GTEST_SKIP() << "root ignores folder permissions";
  const Dataset ds = small_dataset();
  const fs::path out = dir_ / "out";
  fs::create_directories(out / "other");
  fs::permissions(out / "other", fs::perms::owner_read | fs::perms::owner_exec);
  const Error e = error_of([&] { write_dataset(out, ds, {random_run(5, 1), random_run(5, 2)}); });
  expect_contains(e.what(), {"step run.csv", "temporary file"});
  EXPECT_FALSE(fs::exists(out / "dataset.json"));
  fs::permissions(out / "other", fs::perms::owner_all);
  EXPECT_EQ(temp_files(out), std::vector<std::string>{});
}

TEST_F(DatasetTest, WriteRunCsvReplacesAtomically) {
  const fs::path csv = dir_ / "run.csv";
  write_text(csv, "old content");
  const RunData d = random_run(20, 5);
  write_run_csv(csv, d);
  expect_same_data(read_run_csv(csv), d);
  EXPECT_EQ(temp_files(dir_), std::vector<std::string>{});
  const Error e = error_of([&] { write_run_csv(dir_ / "no such folder" / "x.csv", d); });
  expect_contains(e.what(), {"x.csv", "temporary file"});
}

// --- the real datasets in ../shared/datasets
// ---------------------------------------------------------

TEST(RealDatasets, EmpsLoads) {
  ALPHAINV_SKIP_WITHOUT_SHARED_DATASET("emps");
  const Dataset ds = read_dataset_index(kSharedDatasets / "emps");
  EXPECT_EQ(ds.joint, "prismatic");
  EXPECT_EQ(ds.position_unit, "m");
  EXPECT_EQ(ds.command_unit, "V");
  EXPECT_EQ(ds.sample_rate_hz, 1000.0);
  EXPECT_EQ(ds.controller.kd, 243.45);
  EXPECT_EQ(ds.controller.derivative_on, DerivativeOn::kMeasurement);
  EXPECT_EQ(ds.controller.v_limit, 10.0);
  expect_contains(ds.extra_json, {"EMPS benchmark"});
  ASSERT_EQ(ds.runs.size(), 1u);
  EXPECT_EQ(ds.runs[0].kind, "other");
  const RunData d = read_run(ds, 0);
  ASSERT_EQ(d.size(), 24841u);
  EXPECT_EQ(d.t.front(), 0.0);
  EXPECT_EQ(d.r.front(), 0.00010782208);
  EXPECT_NEAR(d.t.back(), 24.84, 1e-9);
  EXPECT_TRUE(d.extra_columns.empty());
}

TEST(RealDatasets, PendulumLoads) {
  ALPHAINV_SKIP_WITHOUT_SHARED_DATASET("xl330_pendulum");
  const Dataset ds = read_dataset_index(kSharedDatasets / "xl330_pendulum");
  EXPECT_EQ(ds.joint, "pendulum");
  EXPECT_EQ(ds.position_unit, "rad");
  EXPECT_EQ(ds.command_unit, "pwm");
  EXPECT_FALSE(ds.sample_rate_hz.has_value());
  ASSERT_EQ(ds.runs.size(), 16u);
  const double kp[] = {254.0, 508.0, 1016.0, 2032.0};
  bool saw_free_fall = false;
  for (std::size_t i = 0; i < ds.runs.size(); ++i) {
    SCOPED_TRACE(ds.runs[i].file);
    EXPECT_EQ(ds.runs[i].controller.kp, kp[i / 4]);
    EXPECT_EQ(ds.runs[i].controller.v_limit, 885.0);  // inherited from the dataset
    EXPECT_EQ(ds.runs[i].controller.ki, 0.0);
    expect_contains(ds.runs[i].extra_json, {"\"trajectory\"", "\"servo_kp_register\""});
    const RunData d = read_run(ds, i);
    EXPECT_GT(d.size(), 1000u);
    const auto* torque_enable = d.column("torque_enable");
    ASSERT_NE(torque_enable, nullptr);
    ASSERT_EQ(torque_enable->size(), d.size());
    for (double x : *torque_enable) {
      EXPECT_TRUE(x == 0.0 || x == 1.0) << x;
      saw_free_fall = saw_free_fall || x == 0.0;
    }
  }
  EXPECT_TRUE(saw_free_fall) << "lift_and_drop runs switch the torque off";
}

// --- issue #13: inputs checked for sense, and what an interrupted writer leaves -------------

// Finding 13: a duplicate run entry was used twice without a word.
TEST_F(DatasetTest, ADuplicateRunEntryIsRefusedNamingBothEntries) {
  write_text(dir_ / "runs" / "a.csv", kGoodCsv);
  write_text(dir_ / "dataset.json",
             index_json(R"({"file": "runs/a.csv", "kind": "step"}, {"file": "runs/b.csv",
             "kind": "step"}, {"file": "runs/./a.csv", "kind": "step"})"));
  write_text(dir_ / "runs" / "b.csv", kGoodCsv);
  const Error e = error_of([&] { read_dataset_index(dir_); });
  EXPECT_EQ(e.field(), "runs[2].file");
  EXPECT_NE(std::string(e.what()).find("duplicate run entry: 'runs/./a.csv' is already runs[0]"),
            std::string::npos) << e.what();
}

// Finding 13: an all-zero run and v = 1e300 were fitted without a note.
TEST_F(DatasetTest, ReadRunRefusesARunWithoutInformationAndValuesNoMeasurementHas) {
  write_text(dir_ / "dataset.json", index_json(R"({"file": "zero.csv", "kind": "step"},
             {"file": "huge.csv", "kind": "step"}, {"file": "edge.csv", "kind": "step"})"));
  write_text(dir_ / "zero.csv", "t,r,theta,v,gamma1\n0,0,0,0,1.0\n0.001,0,0,-0,1.0\n");
  write_text(dir_ / "huge.csv", "t,r,theta,v\n0,0,0,0\n0.001,0.1,0.01,1e300\n");
  write_text(dir_ / "edge.csv", "t,r,theta,v\n0,0,0,-1e9\n0.001,0,0,1e9\n");
  const Dataset ds = read_dataset_index(dir_);
  const Error zero = error_of([&] { read_run(ds, 0); });
  EXPECT_EQ(zero.file(), (dir_ / "zero.csv").string());
  EXPECT_NE(std::string(zero.what()).find("zero in every row: the run carries no information"),
            std::string::npos) << zero.what();
  const Error huge = error_of([&] { read_run(ds, 1); });
  EXPECT_EQ(huge.line(), 3);
  EXPECT_EQ(huge.field(), "v");
  EXPECT_NE(std::string(huge.what()).find("found 1e+300"), std::string::npos) << huge.what();
  EXPECT_EQ(read_run(ds, 2).v[1], 1e9);  // the bound itself is accepted
  EXPECT_EQ(read_run_csv(dir_ / "huge.csv").v[1], 1e300);  // the CSV layer reads any double
}

// Finding 9: a recording killed inside a write leaves a last line without its end. The reader
// drops it when dataset.json says "ended": "interrupted", and only then.
TEST_F(DatasetTest, AnInterruptedDatasetLosesOnlyItsIncompleteLastLine) {
  const std::string torn = std::string(kGoodCsv) + "0.002,0.2,0.0";
  write_text(dir_ / "run.csv", torn);
  write_text(dir_ / "dataset.json",
             index_json(R"({"file": "run.csv", "kind": "step"})", R"("ended": "interrupted", )"));
  const Dataset ds = read_dataset_index(dir_);
  EXPECT_TRUE(ds.interrupted);
  const RunData run = read_run(ds, 0);
  ASSERT_EQ(run.size(), 2u);
  EXPECT_EQ(run.v[1], 1.5);
  write_text(dir_ / "run.csv", std::string(kGoodCsv) + "0.002,0.2,0.0,2");  // cut inside a number
  EXPECT_EQ(read_run(read_dataset_index(dir_), 0).size(), 2u);

  // A dataset that ended: the same line is an error, as before.
  write_text(dir_ / "run.csv", torn);
  write_text(dir_ / "dataset.json",
             index_json(R"({"file": "run.csv", "kind": "step"})", R"("ended": "completed", )"));
  const Dataset done = read_dataset_index(dir_);
  EXPECT_FALSE(done.interrupted);
  const Error e = error_of([&] { read_run(done, 0); });
  EXPECT_EQ(e.line(), 4);
}

}  // namespace
}  // namespace alphainv

TEST(RunDataRows, AWindowKeepsEveryColumn) {
  alphainv::RunData d;
  for (int k = 0; k < 6; ++k) {
    d.t.push_back(0.001 * k);
    d.r.push_back(1.0 + k);
    d.theta.push_back(2.0 + k);
    d.v.push_back(3.0 + k);
    d.extra_columns["torque_enable"].push_back(k < 3 ? 1.0 : 0.0);
    d.extra_columns["disturbance_v"].push_back(0.1 * k);
  }
  const alphainv::RunData w = d.rows(2, 5);
  ASSERT_EQ(w.size(), 3u);
  EXPECT_EQ(w.t, (std::vector<double>{0.002, 0.003, 0.004}));
  EXPECT_EQ(w.r, (std::vector<double>{3.0, 4.0, 5.0}));
  EXPECT_EQ(w.theta, (std::vector<double>{4.0, 5.0, 6.0}));
  EXPECT_EQ(w.v, (std::vector<double>{5.0, 6.0, 7.0}));
  EXPECT_EQ(*w.column("torque_enable"), (std::vector<double>{1.0, 0.0, 0.0}));
  EXPECT_DOUBLE_EQ((*w.column("disturbance_v"))[2], 0.4);
  EXPECT_EQ(d.rows(6, 6).size(), 0u);
  EXPECT_EQ(alphainv::test::error_of([&] { (void)d.rows(4, 7); }).field(), "end");
  EXPECT_EQ(alphainv::test::error_of([&] { (void)d.rows(5, 4); }).field(), "end");
}
