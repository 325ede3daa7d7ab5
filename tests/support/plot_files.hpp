#pragma once
// Test helpers for omni_fit's figures: a scoped temporary folder, the rows of a gnuplot .dat
// block, whether gnuplot is installed.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include <gtest/gtest.h>

#include "support/files.hpp"

namespace alphainv::test {

/// A fresh folder (fresh_temp_dir(suite, name)), created, removed when the test ends.
struct ScopedTempDir {
  ScopedTempDir(const std::string& suite, const std::string& name)
      : path(fresh_temp_dir(suite, name)) {
    std::filesystem::create_directories(path);
  }
  ~ScopedTempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  std::filesystem::path path;
};

/// The numeric rows of block `index` of a .dat file (blocks separated by two blank lines; `#`
/// lines are comments; a row ends at its first quoted label cell).
inline std::vector<std::vector<double>> read_dat_block(const std::filesystem::path& file,
                                                       int index) {
  std::ifstream in(file);
  EXPECT_TRUE(in) << file;
  std::vector<std::vector<double>> rows;
  std::string line;
  int block = 0, blanks = 0;
  while (std::getline(in, line)) {
    if (line.empty()) {
      if (++blanks == 2) ++block;
      continue;
    }
    blanks = 0;
    if (line[0] == '#' || block != index) continue;
    std::istringstream s(line);
    std::vector<double> row;
    std::string cell;
    while (s >> cell && cell[0] != '\'') row.push_back(cell == "NaN" ? std::nan("") : std::stod(cell));
    rows.push_back(row);
  }
  return rows;
}

inline bool gnuplot_installed() {
  return std::system("command -v gnuplot > /dev/null 2>&1") == 0;
}

}  // namespace alphainv::test
