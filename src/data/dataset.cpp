/// \file dataset.cpp
/// Reader and atomic writer of `alphainv-dataset/1` (see include/alphainv/data/dataset.hpp and
/// docs/dataset-format.md). The CSV reader is hand-written and fuzzed (tests/fuzz/).

#include "alphainv/data/dataset.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <system_error>
#include <utility>

#include "alphainv/error.hpp"
#include "common/atomic_file.hpp"
#include "common/format.hpp"
#include "read_file.hpp"

namespace alphainv {
namespace {

namespace fs = std::filesystem;
using data_detail::read_file;
// Ordered objects keep the key order of the file, so rewriting a dataset keeps its layout.
using json = nlohmann::ordered_json;

constexpr std::array<std::string_view, 4> kRequiredColumns = {"t", "r", "theta", "v"};
/// Optional columns the format names: read strictly, like the required ones.
constexpr std::array<std::string_view, 5> kKnownOptionalColumns = {
    "gamma1", "gamma2", "disturbance_v", "torque_enable", "v_comp"};
constexpr std::array<std::string_view, 5> kRunKinds = {"sine", "square", "step", "chirp", "other"};
constexpr std::array<std::string_view, 5> kControllerKeys = {"kp", "ki", "kd", "derivative_on",
                                                             "v_limit"};
/// Deepest nesting of JSON arrays/objects accepted in dataset.json (keeps recursion bounded).
constexpr int kMaxJsonDepth = 64;
/// Most keys in one JSON object of dataset.json (ordered objects insert in linear time).
constexpr std::size_t kMaxJsonKeys = 4096;
constexpr std::string_view kUtf8Bom = "\xEF\xBB\xBF";
constexpr const char* kIndexName = "dataset.json";

template <std::size_t N>
bool contains(const std::array<std::string_view, N>& set, std::string_view s) {
  return std::find(set.begin(), set.end(), s) != set.end();
}

// --- small text helpers
// ---------------------------------------------------------------------------

/// Untrusted text for an error message: in single quotes, non-printable bytes as \xNN, cut at 40.
std::string quote(std::string_view s) {
  constexpr std::size_t kMaxShown = 40;
  std::string out = "'";
  for (std::size_t i = 0; i < s.size() && i < kMaxShown; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7F && c != '\\') {
      out += static_cast<char>(c);
    } else {
      static constexpr char kHex[] = "0123456789abcdef";
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 0xF];
    }
  }
  if (s.size() > kMaxShown) out += "...";
  out += "'";
  return out;
}

bool is_blank_char(char c) { return c == ' ' || c == '\t'; }
bool is_space_char(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank_char(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank_char(s.back())) s.remove_suffix(1);
  return s;
}

bool is_blank(std::string_view s) { return std::all_of(s.begin(), s.end(), is_blank_char); }

// --- numbers
// ----------------------------------------------------------------------------------------

enum class NumberStatus { kOk, kNotANumber, kNotFinite, kOutOfRange };

/// True if `s` spells NaN or infinity the way strtod would accept it ("nan", "-Inf", "infinity").
bool spells_non_finite(std::string_view s) {
  if (!s.empty() && (s.front() == '+' || s.front() == '-')) s.remove_prefix(1);
  if (s.size() < 3) return false;
  std::string head;
  for (std::size_t i = 0; i < 3; ++i) head += static_cast<char>(s[i] | 0x20);  // ASCII lower case
  return head == "nan" || head == "inf";
}

/// Parses a whole cell as a number in plain decimal or exponent notation:
/// [+-]? (digits [. digits?] | . digits) ([eE] [+-]? digits)?. No hex, no NaN, no infinity.
NumberStatus parse_number(std::string_view s, double& out) {
  std::size_t i = 0;
  const std::size_t n = s.size();
  if (i < n && (s[i] == '+' || s[i] == '-')) ++i;
  std::size_t mantissa_digits = 0;
  while (i < n && is_digit(s[i])) ++i, ++mantissa_digits;
  if (i < n && s[i] == '.') {
    ++i;
    while (i < n && is_digit(s[i])) ++i, ++mantissa_digits;
  }
  if (mantissa_digits == 0) {
    return spells_non_finite(s) ? NumberStatus::kNotFinite : NumberStatus::kNotANumber;
  }
  if (i < n && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < n && (s[i] == '+' || s[i] == '-')) ++i;
    std::size_t exponent_digits = 0;
    while (i < n && is_digit(s[i])) ++i, ++exponent_digits;
    if (exponent_digits == 0) return NumberStatus::kNotANumber;
  }
  if (i != n) return NumberStatus::kNotANumber;
  // std::from_chars takes no leading '+'.
  const std::string_view body = s.front() == '+' ? s.substr(1) : s;
  double value = 0.0;
  const auto res = std::from_chars(body.data(), body.data() + body.size(), value);
  if (res.ec == std::errc::result_out_of_range) return NumberStatus::kOutOfRange;
  if (res.ec != std::errc() || res.ptr != body.data() + body.size())
    return NumberStatus::kNotANumber;
  if (!std::isfinite(value)) return NumberStatus::kNotFinite;
  out = value;
  return NumberStatus::kOk;
}

std::string describe_bad_number(NumberStatus status, std::string_view cell, std::size_t column) {
  const std::string where = " (column " + std::to_string(column + 1) + ")";
  switch (status) {
    case NumberStatus::kNotFinite:
      return "expected a finite number, found " + quote(cell) + where;
    case NumberStatus::kOutOfRange:
      return "expected a number within the range of a double (about 4.9e-324 to 1.8e308), found " +
             quote(cell) + where;
    case NumberStatus::kNotANumber:
    case NumberStatus::kOk:
      break;
  }
  if (cell.empty()) return "expected a number, found an empty cell" + where;
  return "expected a number (plain decimal or exponent notation), found " + quote(cell) + where;
}

// --- CSV lines
// --------------------------------------------------------------------------------------

/// Splits text into lines at '\n', dropping one '\r' before it (CRLF). Numbers lines from 1.
class LineReader {
 public:
  explicit LineReader(std::string_view text) : text_(text) {}

  /// The next line, without its line end; false at the end of the text. A final line end does
  /// not start another (empty) line.
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    const std::size_t end = text_.find('\n', pos_);
    if (end == std::string_view::npos) {
      line = text_.substr(pos_);
      pos_ = text_.size();
    } else {
      line = text_.substr(pos_, end - pos_);
      pos_ = end + 1;
    }
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    ++line_no_;
    return true;
  }

  long line_no() const { return line_no_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  long line_no_ = 0;
};

void check_no_stray_cr(std::string_view line, const std::string& file, long line_no) {
  if (line.find('\r') != std::string_view::npos) {
    throw Error("expected LF or CRLF line ends, found a carriage return inside the line", file,
                line_no);
  }
}

/// Calls f(cell) for each comma-separated cell of `line` (cells are trimmed of spaces and tabs).
template <typename F>
void for_each_cell(std::string_view line, F&& f) {
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    if (comma == std::string_view::npos) {
      f(trim(line.substr(start)));
      return;
    }
    f(trim(line.substr(start, comma - start)));
    start = comma + 1;
  }
}

// --- files
// ------------------------------------------------------------------------------------------

// --- JSON reading
// -----------------------------------------------------------------------------------

/// "a string \"abc\"", "a number 3", "null", "an object", ... for error messages.
std::string describe_json(const json& v) {
  switch (v.type()) {
    case json::value_t::object:
      return "an object";
    case json::value_t::array:
      return "an array";
    case json::value_t::null:
      return "null";
    case json::value_t::string:
      return "a string " + quote(v.get_ref<const std::string&>());
    case json::value_t::boolean:
      return v.get<bool>() ? "true" : "false";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float:
      return "the number " + quote(v.dump());
    default:
      return std::string("a ") + v.type_name();
  }
}

/// Parses JSON text, rejecting duplicate keys and nesting deeper than kMaxJsonDepth.
json parse_json(std::string_view text, const std::string& file) {
  std::vector<std::set<std::string>> keys_seen;  // one set per open object
  const json::parser_callback_t check = [&](int depth, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start:
      case json::parse_event_t::array_start:
        if (depth >= kMaxJsonDepth) {
          throw Error("expected at most " + std::to_string(kMaxJsonDepth) +
                          " levels of nested arrays and objects",
                      file);
        }
        if (event == json::parse_event_t::object_start) keys_seen.emplace_back();
        break;
      case json::parse_event_t::object_end:
        if (!keys_seen.empty()) keys_seen.pop_back();
        break;
      case json::parse_event_t::key:
        if (!keys_seen.empty() && parsed.is_string()) {
          const std::string& key = parsed.get_ref<const std::string&>();
          if (!keys_seen.back().insert(key).second) {
            throw Error("duplicate key: a JSON object may hold each key once", file, 0, key);
          }
          if (keys_seen.back().size() > kMaxJsonKeys) {
            throw Error("expected at most " + std::to_string(kMaxJsonKeys) + " keys in one object",
                        file, 0, key);
          }
        }
        break;
      default:
        break;
    }
    return true;
  };
  try {
    return json::parse(text.begin(), text.end(), check);
  } catch (const json::parse_error& e) {
    // e.byte is the 1-based position of the byte that failed; turn it into line and column.
    const std::size_t end = std::min<std::size_t>(e.byte == 0 ? 0 : e.byte - 1, text.size());
    const std::string_view before = text.substr(0, end);
    const long line = 1 + static_cast<long>(std::count(before.begin(), before.end(), '\n'));
    const std::size_t last_nl = before.rfind('\n');
    const std::size_t column = last_nl == std::string_view::npos ? end + 1 : end - last_nl;
    std::string detail = e.what();
    const std::size_t at = detail.find("column ");
    const std::size_t colon = at == std::string::npos ? std::string::npos : detail.find(": ", at);
    if (colon != std::string::npos) detail = detail.substr(colon + 2);
    throw Error("malformed JSON at column " + std::to_string(column) + ": " + detail, file, line);
  } catch (const json::out_of_range& e) {
    // nlohmann reports a number beyond the range of a double ("1e400") without its position:
    // find the number it quotes in the text for the line.
    const std::string what = e.what();
    const std::size_t open = what.rfind(" '");
    long line = 0;
    std::string token;
    if (open != std::string::npos && what.size() > open + 3 && what.back() == '\'') {
      token = what.substr(open + 2, what.size() - open - 3);
      const std::size_t at = token.empty() ? std::string_view::npos : text.find(token);
      if (at != std::string_view::npos) {
        line = 1 + static_cast<long>(std::count(
                       text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
      }
    }
    throw Error("expected a number within the range of a double, found " + quote(token), file,
                line);
  } catch (const json::exception& e) {
    throw Error(std::string("cannot parse JSON: ") + e.what(), file);
  }
}

/// Reads typed values out of a parsed dataset.json, naming `file` and the key path in errors.
class IndexReader {
 public:
  explicit IndexReader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const std::string& message, const std::string& key) const {
    throw Error(message, file_, 0, key);
  }

  static std::string path(const std::string& parent, std::string_view key) {
    return parent.empty() ? std::string(key) : parent + "." + std::string(key);
  }

  /// The value under `key`, or nullptr when absent or null.
  static const json* find(const json& object, const char* key) {
    const auto it = object.find(key);
    if (it == object.end() || it->is_null()) return nullptr;
    return &*it;
  }

  void expect_object(const json& v, const std::string& key) const {
    if (!v.is_object()) fail("expected an object, found " + describe_json(v), key);
  }

  double number(const json& v, const std::string& key) const {
    if (!v.is_number()) fail("expected a number, found " + describe_json(v), key);
    const double x = v.get<double>();
    if (!std::isfinite(x)) fail("expected a finite number, found " + describe_json(v), key);
    return x;
  }

  std::optional<double> optional_number(const json& object, const char* key,
                                        const std::string& parent) const {
    const json* v = find(object, key);
    if (v == nullptr) return std::nullopt;
    return number(*v, path(parent, key));
  }

  std::optional<double> optional_positive(const json& object, const char* key,
                                          const std::string& parent) const {
    const auto x = optional_number(object, key, parent);
    if (x && !(*x > 0.0)) {
      fail("expected a number greater than 0, found " + common::shortest(*x), path(parent, key));
    }
    return x;
  }

  std::string string(const json& v, const std::string& key) const {
    if (!v.is_string()) fail("expected a string, found " + describe_json(v), key);
    return v.get<std::string>();
  }

  std::optional<std::string> optional_string(const json& object, const char* key,
                                             const std::string& parent) const {
    const json* v = find(object, key);
    if (v == nullptr) return std::nullopt;
    return string(*v, path(parent, key));
  }

  const json& required(const json& object, const char* key, const std::string& parent,
                       const std::string& expected) const {
    const json* v = find(object, key);
    if (v == nullptr) fail("missing required key: expected " + expected, path(parent, key));
    return *v;
  }

  /// Applies a `controller` object (keys absent keep their value in `c`); `parent` is its path.
  void apply_controller(const json& obj, const std::string& parent, Controller& c) const {
    expect_object(obj, parent);
    if (auto x = optional_number(obj, "kp", parent)) c.kp = *x;
    if (auto x = optional_number(obj, "ki", parent)) c.ki = *x;
    if (auto x = optional_number(obj, "kd", parent)) c.kd = *x;
    if (auto s = optional_string(obj, "derivative_on", parent)) {
      if (*s == "error") {
        c.derivative_on = DerivativeOn::kError;
      } else if (*s == "measurement") {
        c.derivative_on = DerivativeOn::kMeasurement;
      } else {
        fail("expected \"error\" or \"measurement\", found " + quote(*s),
             path(parent, "derivative_on"));
      }
    }
    const auto it = obj.find("v_limit");
    if (it != obj.end()) {
      if (it->is_null()) {
        // explicit null: no limit (also overrides an inherited one)
        c.v_limit = std::numeric_limits<double>::infinity();
      } else {
        const std::string key = path(parent, "v_limit");
        const double x = number(*it, key);
        if (!(x > 0.0))
          fail("expected null or a number greater than 0, found " + common::shortest(x), key);
        c.v_limit = x;
      }
    }
  }

  /// Applies `controller` then the `kp` shorthand of `object` (the top level or a run) to `c`.
  void apply_controller_keys(const json& object, const std::string& parent,
                             Controller& c) const {
    const json* controller = find(object, "controller");
    if (controller != nullptr) apply_controller(*controller, path(parent, "controller"), c);
    if (auto kp = optional_number(object, "kp", parent)) {
      const json* inner = controller != nullptr ? find(*controller, "kp") : nullptr;
      if (inner != nullptr && inner->is_number() && inner->get<double>() != *kp) {
        fail("the shorthand kp = " + common::shortest(*kp) +
                 " contradicts controller.kp = " + common::shortest(inner->get<double>()),
             path(parent, "kp"));
      }
      c.kp = *kp;
    }
  }

  /// Checks a run's `file`: a non-empty relative path that stays inside the dataset folder.
  void check_run_path(const std::string& file, const std::string& key) const {
    if (file.empty()) fail("expected a non-empty relative path to a CSV file", key);
    if (file.find('\0') != std::string::npos) fail("expected a path without NUL characters", key);
    const fs::path p(file);
    if (p.has_root_path()) {
      fail("expected a path relative to the dataset folder, found " + quote(file), key);
    }
    for (const auto& part : p) {
      if (part == "..")
        fail("expected a path inside the dataset folder, found " + quote(file), key);
    }
    const fs::path normal = p.lexically_normal();
    if (normal.empty() || normal == "." || !normal.has_filename()) {
      fail("expected a path to a file, found " + quote(file), key);
    }
    if (normal == kIndexName)
      fail("expected the path of a run CSV file, found the index dataset.json itself", key);
  }

  RunInfo run(const json& obj, std::size_t i, const Controller& base) const {
    const std::string parent = "runs[" + std::to_string(i) + "]";
    expect_object(obj, parent);
    RunInfo info;
    info.file = string(required(obj, "file", parent, "a CSV path relative to the dataset folder"),
                       path(parent, "file"));
    check_run_path(info.file, path(parent, "file"));
    info.kind = string(required(obj, "kind", parent, "one of sine, square, step, chirp, other"),
                       path(parent, "kind"));
    if (!contains(kRunKinds, info.kind)) {
      fail("expected one of sine, square, step, chirp, other, found " + quote(info.kind),
           path(parent, "kind"));
    }
    info.freq_hz = optional_positive(obj, "freq_hz", parent);
    info.amplitude_rad = optional_number(obj, "amplitude_rad", parent);
    if (info.kind == "sine" || info.kind == "square") {
      const std::string why = "a " + info.kind + " run needs it";
      if (!info.freq_hz)
        fail("missing required key: expected a frequency [Hz] (" + why + ")",
             path(parent, "freq_hz"));
      if (!info.amplitude_rad)
        fail("missing required key: expected an amplitude (" + why + ")",
             path(parent, "amplitude_rad"));
    }
    info.gamma1_deg = optional_number(obj, "gamma1_deg", parent);
    info.gamma2_deg = optional_number(obj, "gamma2_deg", parent);
    info.controller = base;
    apply_controller_keys(obj, parent, info.controller);
    info.extra_json = obj.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    return info;
  }

 private:
  std::string file_;
};

// --- validation of data to write
// --------------------------------------------------------------------

/// Throws unless `data` would read back unchanged through parse_run_csv (with default limits).
void validate_run_data(const RunData& data, const std::string& file) {
  const ReadLimits limits;
  const std::size_t n = data.t.size();
  if (n == 0) throw Error("expected at least one sample, found none", file, 0, "t");
  if (n > limits.max_rows) {
    throw Error("expected at most " + std::to_string(limits.max_rows) + " samples, found " +
                    std::to_string(n),
                file, 0, "t");
  }
  if (kRequiredColumns.size() + data.extra_columns.size() > limits.max_columns) {
    throw Error("expected at most " + std::to_string(limits.max_columns) + " columns, found " +
                    std::to_string(kRequiredColumns.size() + data.extra_columns.size()),
                file);
  }
  auto check_column = [&](const std::string& name, const std::vector<double>& values) {
    if (values.size() != n) {
      throw Error("expected " + std::to_string(n) + " values (as many as t), found " +
                      std::to_string(values.size()),
                  file, 0, name);
    }
    for (std::size_t k = 0; k < n; ++k) {
      if (!std::isfinite(values[k])) {
        throw Error("expected finite values, found " + common::shortest(values[k]) + " at index " +
                        std::to_string(k),
                    file, 0, name);
      }
    }
  };
  check_column("t", data.t);
  check_column("r", data.r);
  check_column("theta", data.theta);
  check_column("v", data.v);
  for (std::size_t k = 1; k < n; ++k) {
    if (!(data.t[k] > data.t[k - 1])) {
      throw Error("expected strictly increasing times, found " + common::shortest(data.t[k]) +
                      " at index " + std::to_string(k) + " after " + common::shortest(data.t[k - 1]),
                  file, 0, "t");
    }
  }
  for (const auto& [name, values] : data.extra_columns) {
    const bool bad_name = name.empty() || trim(name).size() != name.size() ||
                          name.find_first_of(",\"\r\n") != std::string::npos ||
                          contains(kRequiredColumns, name);
    if (bad_name) {
      throw Error(
          "expected a column name that is not t, r, theta or v, not empty, without "
          "surrounding spaces and without , \" CR or LF; found " +
              quote(name),
          file);
    }
    check_column(name, values);
  }
}

/// Throws unless run `data` can be a measurement (read_run()'s checks).
void check_run_sense(const RunData& data, const std::string& file) {
  bool any_nonzero = false;
  for (const char* name : {"r", "theta", "v"}) {
    const std::vector<double>& col = *data.column(name);
    for (std::size_t k = 0; k < col.size(); ++k) {
      if (std::abs(col[k]) > kMaxPhysicalMagnitude) {
        throw Error("expected |" + std::string(name) + "| <= " +
                        common::shortest(kMaxPhysicalMagnitude) + " (a physical value), found " +
                        common::shortest(col[k]),
                    file, static_cast<long>(k + 2), name);
      }
      any_nonzero = any_nonzero || col[k] != 0.0;
    }
  }
  if (!any_nonzero) {
    throw Error("r, theta and v are zero in every row: the run carries no information", file, 0,
                "v");
  }
}

}  // namespace

// --- RunData
// ----------------------------------------------------------------------------------------

RunData RunData::rows(std::size_t begin, std::size_t end) const {
  if (begin > end || end > size()) {
    throw Error("expected rows begin <= end <= " + std::to_string(size()) + ", got [" +
                    std::to_string(begin) + ", " + std::to_string(end) + ")",
                {}, 0, "end");
  }
  const auto b = static_cast<std::ptrdiff_t>(begin), e = static_cast<std::ptrdiff_t>(end);
  auto cut = [b, e](const std::vector<double>& x) {
    return x.size() < static_cast<std::size_t>(e) ? std::vector<double>{}
                                                  : std::vector<double>(x.begin() + b, x.begin() + e);
  };
  RunData out;
  out.t = cut(t);
  out.r = cut(r);
  out.theta = cut(theta);
  out.v = cut(v);
  for (const auto& [name, col] : extra_columns) out.extra_columns.emplace(name, cut(col));
  out.ignored_columns = ignored_columns;
  return out;
}

const std::vector<double>* RunData::column(std::string_view name) const {
  if (name == "t") return &t;
  if (name == "r") return &r;
  if (name == "theta") return &theta;
  if (name == "v") return &v;
  const auto it = extra_columns.find(std::string(name));
  return it == extra_columns.end() ? nullptr : &it->second;
}

bool is_format_column(std::string_view name) {
  return contains(kRequiredColumns, name) || contains(kKnownOptionalColumns, name);
}

// --- reading
// ----------------------------------------------------------------------------------------

// Longer than the house's ~120 lines on purpose: the hardened CSV parser, fuzzed as it stands
// (tests/fuzz/fuzz_read_run.cpp); the architecture step moved it without rewriting it.
RunData parse_run_csv(std::string_view text, const std::string& name, const ReadLimits& limits) {
  if (text.size() > limits.max_csv_bytes) {
    throw Error("file is " + std::to_string(text.size()) + " bytes; the limit is " +
                    std::to_string(limits.max_csv_bytes) + " bytes",
                name);
  }
  if (text.substr(0, kUtf8Bom.size()) == kUtf8Bom) text.remove_prefix(kUtf8Bom.size());
  if (std::all_of(text.begin(), text.end(), is_space_char)) {
    throw Error("empty file: expected a header line such as 't,r,theta,v'", name, 1);
  }

  // Refuse absurd row counts before allocating: every data row is one line after the header.
  std::string_view body = text;
  while (!body.empty() && is_space_char(body.back())) body.remove_suffix(1);
  const std::size_t lines =
      static_cast<std::size_t>(std::count(body.begin(), body.end(), '\n')) + 1;
  const std::size_t max_data_rows = lines - 1;
  if (max_data_rows > limits.max_rows) {
    throw Error("file has " + std::to_string(max_data_rows) +
                    " lines after the header; the limit is " + std::to_string(limits.max_rows) +
                    " rows",
                name);
  }

  // Header.
  LineReader reader(text);
  std::string_view header;
  reader.next(header);
  check_no_stray_cr(header, name, 1);
  if (is_blank(header)) {
    throw Error("expected a header line naming the columns, found a blank line", name, 1);
  }
  const std::size_t n_columns =
      static_cast<std::size_t>(std::count(header.begin(), header.end(), ',')) + 1;
  if (n_columns > limits.max_columns) {
    throw Error("header has " + std::to_string(n_columns) + " columns; the limit is " +
                    std::to_string(limits.max_columns),
                name, 1);
  }
  std::vector<std::string> names;
  names.reserve(n_columns);
  for_each_cell(header, [&](std::string_view cell) { names.emplace_back(cell); });
  std::map<std::string, std::size_t, std::less<>> index;
  for (std::size_t j = 0; j < names.size(); ++j) {
    const std::string& col = names[j];
    if (col.empty()) {
      throw Error(
          "expected a column name, found an empty one (column " + std::to_string(j + 1) + ")", name,
          1);
    }
    if (col.find('"') != std::string::npos) {
      throw Error("expected a bare column name (quoted fields are not supported), found " +
                      quote(col) + " (column " + std::to_string(j + 1) + ")",
                  name, 1, col);
    }
    const auto [it, inserted] = index.emplace(col, j);
    if (!inserted) {
      throw Error("duplicate column: columns " + std::to_string(it->second + 1) + " and " +
                      std::to_string(j + 1) + " have the same name",
                  name, 1, col);
    }
  }
  for (const std::string_view required : kRequiredColumns) {
    if (index.find(required) == index.end()) {
      std::string found;
      for (const auto& col : names) found += (found.empty() ? "" : ",") + col;
      throw Error(
          "missing required column: the header must name t, r, theta and v; found " + quote(found),
          name, 1, std::string(required));
    }
  }
  const std::size_t t_col = index.find("t")->second;

  // Data rows. A row takes at least n_columns bytes (its commas and line end), so reserving
  // this many rows costs at most one double per byte of input, however the file is shaped.
  const std::size_t reserve_rows = std::min(max_data_rows, body.size() / n_columns);
  std::vector<bool> strict(n_columns), dropped(n_columns, false);
  std::vector<std::vector<double>> values(n_columns);
  for (std::size_t j = 0; j < n_columns; ++j) {
    strict[j] = contains(kRequiredColumns, names[j]) || contains(kKnownOptionalColumns, names[j]);
    values[j].reserve(reserve_rows);
  }
  std::size_t rows = 0;
  long first_blank_line = 0;  // first blank line after the header; 0: none yet
  long previous_line = 0;
  std::string_view line;
  while (reader.next(line)) {
    const long line_no = reader.line_no();
    check_no_stray_cr(line, name, line_no);
    if (is_blank(line)) {
      if (first_blank_line == 0) first_blank_line = line_no;
      continue;  // fine at the end of the file; an error if another row follows
    }
    if (first_blank_line != 0) {
      throw Error(
          "blank line between rows: expected the rows to follow each other (next row on "
          "line " +
              std::to_string(line_no) + ")",
          name, first_blank_line);
    }
    const std::size_t cells =
        static_cast<std::size_t>(std::count(line.begin(), line.end(), ',')) + 1;
    if (cells != n_columns) {
      throw Error("expected " + std::to_string(n_columns) + " cells as in the header, found " +
                      std::to_string(cells),
                  name, line_no);
    }
    std::size_t j = 0;
    for_each_cell(line, [&](std::string_view cell) {
      const std::size_t col = j++;
      if (dropped[col]) return;
      double x = 0.0;
      const NumberStatus status = parse_number(cell, x);
      if (status == NumberStatus::kOk) {
        values[col].push_back(x);
      } else if (strict[col]) {
        throw Error(describe_bad_number(status, cell, col), name, line_no, names[col]);
      } else {  // an unknown column that is not numeric: ignore it, as the format says
        dropped[col] = true;
        std::vector<double>().swap(values[col]);
      }
    });
    const std::vector<double>& t = values[t_col];
    if (rows > 0 && !(t[rows] > t[rows - 1])) {
      throw Error("expected t strictly increasing, found " + common::shortest(t[rows]) + " after " +
                      common::shortest(t[rows - 1]) + " on line " + std::to_string(previous_line),
                  name, line_no, "t");
    }
    previous_line = line_no;
    ++rows;
  }
  if (rows == 0) {
    throw Error("expected at least one data row after the header, found none", name, 2);
  }

  RunData data;
  for (std::size_t j = 0; j < n_columns; ++j) {
    const std::string& col = names[j];
    if (dropped[j]) {
      data.ignored_columns.push_back(col);
    } else if (col == "t") {
      data.t = std::move(values[j]);
    } else if (col == "r") {
      data.r = std::move(values[j]);
    } else if (col == "theta") {
      data.theta = std::move(values[j]);
    } else if (col == "v") {
      data.v = std::move(values[j]);
    } else {
      data.extra_columns.emplace(col, std::move(values[j]));
    }
  }
  return data;
}

RunData read_run_csv(const fs::path& csv, const ReadLimits& limits) {
  return parse_run_csv(read_file(csv, limits.max_csv_bytes), csv.string(), limits);
}

Dataset parse_dataset_index(std::string_view text, const fs::path& dir) {
  const std::string file = (dir / kIndexName).string();
  json root = parse_json(text, file);
  const IndexReader in(file);
  if (!root.is_object()) {
    throw Error("expected a JSON object at the top level, found " + describe_json(root), file, 1);
  }

  const json& format = in.required(root, "format", "", "\"" + std::string(kDatasetFormat) + "\"");
  const std::string format_value = in.string(format, "format");
  if (format_value != kDatasetFormat) {
    in.fail("unsupported format: expected \"" + std::string(kDatasetFormat) + "\", found " +
                quote(format_value),
            "format");
  }

  Dataset ds;
  ds.dir = dir;
  if (auto s = in.optional_string(root, "joint", "")) ds.joint = *s;
  if (auto s = in.optional_string(root, "position_unit", "")) {
    if (*s != "rad" && *s != "m")
      in.fail("expected \"rad\" or \"m\", found " + quote(*s), "position_unit");
    ds.position_unit = *s;
  }
  if (auto s = in.optional_string(root, "command_unit", "")) {
    if (s->empty())
      in.fail("expected a unit such as \"V\" or \"pwm\", found an empty string", "command_unit");
    ds.command_unit = *s;
  }
  ds.sample_rate_hz = in.optional_positive(root, "sample_rate_hz", "");
  in.apply_controller_keys(root, "", ds.controller);

  const json& runs = in.required(root, "runs", "", "a list of run objects");
  if (!runs.is_array())
    in.fail("expected a list of run objects, found " + describe_json(runs), "runs");
  if (runs.empty()) in.fail("expected at least one run, found an empty list", "runs");
  ds.runs.reserve(runs.size());
  std::map<fs::path, std::size_t> files;  // each run file once: a duplicate entry counts twice
  for (std::size_t i = 0; i < runs.size(); ++i) {
    ds.runs.push_back(in.run(runs[i], i, ds.controller));
    const auto [it, inserted] = files.emplace(fs::path(ds.runs[i].file).lexically_normal(), i);
    if (!inserted) {
      in.fail("duplicate run entry: " + quote(ds.runs[i].file) + " is already runs[" +
                  std::to_string(it->second) + "]",
              "runs[" + std::to_string(i) + "].file");
    }
  }
  if (const json* ended = IndexReader::find(root, "ended"); ended != nullptr) {
    ds.interrupted = ended->is_string() && ended->get_ref<const std::string&>() == "interrupted";
  }

  root.erase("runs");
  ds.extra_json = root.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return ds;
}

Dataset read_dataset_index(const fs::path& dir, const ReadLimits& limits) {
  const fs::path index = dir / kIndexName;
  Dataset ds = parse_dataset_index(read_file(index, limits.max_index_bytes), dir);
  for (std::size_t i = 0; i < ds.runs.size(); ++i) {
    const fs::path csv = dir / ds.runs[i].file;
    const std::string key = "runs[" + std::to_string(i) + "].file";
    std::error_code ec;
    const fs::file_status st = fs::status(csv, ec);
    if (st.type() == fs::file_type::not_found) {
      throw Error("run file does not exist: " + csv.string(), index.string(), 0, key);
    }
    if (!fs::is_regular_file(st)) {
      throw Error("expected a regular file: " + csv.string(), index.string(), 0, key);
    }
  }
  return ds;
}

RunData read_run(const Dataset& dataset, std::size_t i, const ReadLimits& limits) {
  if (i >= dataset.runs.size()) {
    throw Error("run index " + std::to_string(i) + " is out of range: the dataset has " +
                    std::to_string(dataset.runs.size()) + " runs",
                (dataset.dir / kIndexName).string(), 0, "runs");
  }
  const fs::path csv = dataset.dir / dataset.runs[i].file;
  std::string text = read_file(csv, limits.max_csv_bytes);
  if (dataset.interrupted && !text.empty() && text.back() != '\n') {
    text.resize(text.rfind('\n') + 1);  // the row its writer died writing (npos + 1 == 0)
  }
  RunData data = parse_run_csv(text, csv.string(), limits);
  check_run_sense(data, csv.string());
  return data;
}

// --- writing
// ----------------------------------------------------------------------------------------

std::string format_run_csv(const RunData& data, const std::string& name) {
  validate_run_data(data, name);
  std::vector<const std::vector<double>*> columns = {&data.t, &data.r, &data.theta, &data.v};
  std::string out = "t,r,theta,v";
  for (const auto& [col, values] : data.extra_columns) {
    out += ',';
    out += col;
    columns.push_back(&values);
  }
  out += '\n';
  const std::size_t n = data.size();
  out.reserve(out.size() + n * columns.size() * 24);
  for (std::size_t k = 0; k < n; ++k) {
    for (std::size_t j = 0; j < columns.size(); ++j) {
      if (j > 0) out += ',';
      common::append_shortest(out, (*columns[j])[k]);
    }
    out += '\n';
  }
  return out;
}

std::string format_dataset_index(const Dataset& ds) {
  const std::string file = kIndexName;
  auto parse_extra = [&](const std::string& text, const std::string& what) {
    if (text.empty()) return json::object();
    json extra;
    try {
      extra = json::parse(text);
    } catch (const json::exception& e) {
      throw Error(std::string("expected JSON text, cannot parse it: ") + e.what(), file, 0, what);
    }
    if (!extra.is_object()) throw Error("expected a JSON object", file, 0, what);
    return extra;
  };
  auto controller_json = [](const json& base, const Controller& c) {
    json out = json::object();
    out["kp"] = c.kp;
    out["ki"] = c.ki;
    out["kd"] = c.kd;
    out["derivative_on"] =
        c.derivative_on == DerivativeOn::kMeasurement ? "measurement" : "error";
    out["v_limit"] = c.has_limit() ? json(c.v_limit) : json(nullptr);
    if (base.is_object()) {  // keys of the format's future, or a lab's own, kept after ours
      for (const auto& [key, value] : base.items()) {
        if (!out.contains(key)) out[key] = value;
      }
    }
    return out;
  };
  auto set_optional = [](json& obj, const char* key, const std::optional<double>& x) {
    if (x) {
      obj[key] = *x;
    } else {
      obj.erase(key);
    }
  };

  // Known keys first, in the order of the format description, then the extra keys.
  json root = json::object();
  const json extra = parse_extra(ds.extra_json, "extra_json");
  root["format"] = kDatasetFormat;
  if (!ds.joint.empty()) root["joint"] = ds.joint;
  root["position_unit"] = ds.position_unit;
  root["command_unit"] = ds.command_unit;
  set_optional(root, "sample_rate_hz", ds.sample_rate_hz);
  root["controller"] =
      controller_json(extra.contains("controller") ? extra["controller"] : json(), ds.controller);
  json runs = json::array();
  for (std::size_t i = 0; i < ds.runs.size(); ++i) {
    const RunInfo& run = ds.runs[i];
    const json run_extra =
        parse_extra(run.extra_json, "runs[" + std::to_string(i) + "].extra_json");
    json obj = json::object();
    obj["file"] = run.file;
    obj["kind"] = run.kind;
    set_optional(obj, "freq_hz", run.freq_hz);
    set_optional(obj, "amplitude_rad", run.amplitude_rad);
    set_optional(obj, "gamma1_deg", run.gamma1_deg);
    set_optional(obj, "gamma2_deg", run.gamma2_deg);
    // Only the keys in which this run's controller differs from the dataset's.
    json overrides = run_extra.contains("controller") && run_extra["controller"].is_object()
                         ? run_extra["controller"]
                         : json::object();
    for (const std::string_view key : kControllerKeys) overrides.erase(std::string(key));
    const Controller& c = run.controller;
    const json full = controller_json(json(), c);
    if (c.kp != ds.controller.kp) overrides["kp"] = full["kp"];
    if (c.ki != ds.controller.ki) overrides["ki"] = full["ki"];
    if (c.kd != ds.controller.kd) overrides["kd"] = full["kd"];
    if (c.derivative_on != ds.controller.derivative_on)
      overrides["derivative_on"] = full["derivative_on"];
    if (c.v_limit != ds.controller.v_limit) overrides["v_limit"] = full["v_limit"];
    if (!overrides.empty()) obj["controller"] = overrides;
    for (const auto& [key, value] : run_extra.items()) {
      if (!obj.contains(key) && key != "controller" && key != "kp" && key != "freq_hz" &&
          key != "amplitude_rad" && key != "gamma1_deg" && key != "gamma2_deg") {
        obj[key] = value;
      }
    }
    runs.push_back(std::move(obj));
  }
  root["runs"] = std::move(runs);
  for (const auto& [key, value] : extra.items()) {
    if (!root.contains(key) && key != "kp" && key != "joint" && key != "sample_rate_hz") {
      root[key] = value;
    }
  }

  std::string text;
  try {
    text = root.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  } catch (const json::exception& e) {  // e.g. a string that is not valid UTF-8
    throw Error(std::string("cannot write JSON: ") + e.what(), file);
  }
  (void)parse_dataset_index(text, fs::path());  // throws, naming the key, unless it reads back
  return text;
}

void write_run_csv(const fs::path& csv, const RunData& data) {
  common::write_file_atomically(csv, format_run_csv(data, csv.string()));
}

void write_dataset(const fs::path& dir, const Dataset& ds, const std::vector<RunData>& data) {
  const fs::path index = dir / kIndexName;
  if (data.size() != ds.runs.size()) {
    throw Error("expected one RunData per run: " + std::to_string(ds.runs.size()) + " runs, " +
                    std::to_string(data.size()) + " RunData",
                index.string(), 0, "runs");
  }
  // Validate everything before writing anything.
  const std::string index_text = format_dataset_index(ds);
  std::set<fs::path> targets;
  for (std::size_t i = 0; i < ds.runs.size(); ++i) {
    const fs::path target = (dir / ds.runs[i].file).lexically_normal();
    if (!targets.insert(target).second) {
      throw Error("two runs name the same file " + quote(ds.runs[i].file), index.string(), 0,
                  "runs[" + std::to_string(i) + "].file");
    }
    validate_run_data(data[i], target.string());
  }

  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error("cannot create the dataset folder: " + ec.message(), dir.string());
  // No index while the runs change: a failure below leaves no dataset.json rather than a stale one.
  fs::remove(index, ec);
  if (ec) throw Error("cannot remove the old index: " + ec.message(), index.string());
  for (std::size_t i = 0; i < ds.runs.size(); ++i) {
    const fs::path target = dir / ds.runs[i].file;
    fs::create_directories(target.parent_path(), ec);
    if (ec) {
      throw Error("cannot create the folder " + target.parent_path().string() + ": " + ec.message(),
                  target.string());
    }
    common::write_file_atomically(target, format_run_csv(data[i], target.string()));
  }
  common::write_file_atomically(index, index_text);
}

}  // namespace alphainv
