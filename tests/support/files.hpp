#pragma once
// Test helpers: a fresh temporary folder per test process, a file's whole text.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

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

}  // namespace alphainv::test
