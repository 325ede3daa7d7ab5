#pragma once
/// \file apps/common/report_numbers.hpp
/// The numbers of the apps' outputs: a cell of a report table (Markdown, the terminal) and a
/// number of a JSON output, each with what it shows when the value is missing or infinite.

#include <nlohmann/json.hpp>
#include <string>

namespace alphainv::apps {

/// `x` as a report table cell: printed with `printf_format` (one double conversion, default
/// "%.4g"); "–" when x is NaN (no value), "∞" or "−∞" when it is infinite.
std::string table_cell(double x, const char* printf_format = "%.4g");

/// `x` as a JSON number, or null when it is not finite (JSON has neither NaN nor infinity).
nlohmann::json json_number(double x);

}  // namespace alphainv::apps
