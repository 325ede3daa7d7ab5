#pragma once
// Test helpers: a fresh temporary folder per test process, a file's whole text.
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace alphainv::test {

/// <tmp>/alphainv_test_<suite>_<pid>_<name>, removed if it exists (not created).
inline std::filesystem::path fresh_temp_dir(const std::string& suite, const std::string& name) {
  const std::filesystem::path p =
      std::filesystem::temp_directory_path() /
      ("alphainv_test_" + suite + "_" + std::to_string(getpid()) + "_" + name);
  std::filesystem::remove_all(p);
  return p;
}

/// The whole text of `path` ("" when it cannot be read).
inline std::string slurp(const std::filesystem::path& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

/// Every name in `dir` (not recursive), sorted.
inline std::vector<std::string> names_in(const std::filesystem::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    out.push_back(e.path().filename().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace alphainv::test
