// Tests of src/common/atomic_file.hpp: the one atomic file writer. It writes and replaces, leaves
// the old target when a write fails (a folder that cannot be written, a target that is a
// folder, a missing folder), names the target and the errno text, and leaves no temporary file.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include "alphainv/error.hpp"
#include "common/atomic_file.hpp"

namespace alphainv::common {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Every name in `dir` (not recursive), sorted.
std::vector<std::string> names_in(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

/// The alphainv::Error that `f` throws, or none.
std::optional<Error> error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e;
  }
  return std::nullopt;
}

class AtomicFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("alphainv_test_atomic_file_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::permissions(dir_, fs::perms::owner_all, ec);
    fs::remove_all(dir_, ec);
  }
  fs::path dir_;
};

TEST_F(AtomicFile, WritesANewFile) {
  const std::string text = std::string("a,b\n1,2\n") + std::string(100000, 'x') + '\0' + "end";
  write_file_atomically(dir_ / "out.csv", text);
  EXPECT_EQ(slurp(dir_ / "out.csv"), text);  // every byte, the NUL too
  EXPECT_EQ(names_in(dir_), std::vector<std::string>{"out.csv"});
}

TEST_F(AtomicFile, WritesAnEmptyFile) {
  write_file_atomically(dir_ / "empty", "");
  EXPECT_TRUE(fs::exists(dir_ / "empty"));
  EXPECT_EQ(fs::file_size(dir_ / "empty"), 0u);
}

TEST_F(AtomicFile, ReplacesAnOldFile) {
  write_file_atomically(dir_ / "model.json", "old, and longer than the new one");
  write_file_atomically(dir_ / "model.json", "new");
  EXPECT_EQ(slurp(dir_ / "model.json"), "new");
  EXPECT_EQ(names_in(dir_), std::vector<std::string>{"model.json"});
}

TEST_F(AtomicFile, RelativeTargetInTheWorkingFolder) {
  const fs::path here = fs::current_path();
  fs::current_path(dir_);
  write_file_atomically("plain.txt", "in the working folder");
  fs::current_path(here);
  EXPECT_EQ(slurp(dir_ / "plain.txt"), "in the working folder");
  EXPECT_EQ(names_in(dir_), std::vector<std::string>{"plain.txt"});
}

TEST_F(AtomicFile, MissingFolderNamesTargetAndErrno) {
  const fs::path target = dir_ / "no such folder" / "x.csv";
  const auto e = error_of([&] { write_file_atomically(target, "data"); });
  ASSERT_TRUE(e) << "no alphainv::Error thrown";
  EXPECT_EQ(e->file(), target.string());
  EXPECT_NE(e->message().find("cannot create temporary file"), std::string::npos) << e->what();
  EXPECT_NE(e->message().find("No such file or directory"), std::string::npos) << e->what();
  EXPECT_EQ(names_in(dir_), std::vector<std::string>{});
}

TEST_F(AtomicFile, TargetThatIsAFolderStaysAndNoTemporaryIsLeft) {
  fs::create_directories(dir_ / "report.md");
  const auto e = error_of([&] { write_file_atomically(dir_ / "report.md", "text"); });
  ASSERT_TRUE(e) << "no alphainv::Error thrown";
  EXPECT_EQ(e->file(), (dir_ / "report.md").string());
  EXPECT_NE(e->message().find("cannot rename"), std::string::npos) << e->what();
  EXPECT_NE(e->message().find("Is a directory"), std::string::npos) << e->what();
  EXPECT_TRUE(fs::is_directory(dir_ / "report.md"));
  EXPECT_EQ(names_in(dir_), std::vector<std::string>{"report.md"});  // the temporary file is gone
}

TEST_F(AtomicFile, UnwritableFolderLeavesTheOldFile) {
  if (::geteuid() == 0) GTEST_SKIP() << "root ignores folder permissions";
  write_file_atomically(dir_ / "model.json", "old");
  fs::permissions(dir_, fs::perms::owner_read | fs::perms::owner_exec);
  const auto e = error_of([&] { write_file_atomically(dir_ / "model.json", "new"); });
  ASSERT_TRUE(e) << "no alphainv::Error thrown";
  fs::permissions(dir_, fs::perms::owner_all);
  EXPECT_NE(e->message().find("Permission denied"), std::string::npos) << e->what();
  EXPECT_EQ(slurp(dir_ / "model.json"), "old");
  EXPECT_EQ(names_in(dir_), std::vector<std::string>{"model.json"});
}

TEST_F(AtomicFile, CommitFileRenamesAWrittenFile) {
  { std::ofstream(dir_ / "fig.png.part", std::ios::binary) << "PNG bytes"; }
  { std::ofstream(dir_ / "fig.png", std::ios::binary) << "an older figure"; }
  commit_file(dir_ / "fig.png.part", dir_ / "fig.png");
  EXPECT_EQ(slurp(dir_ / "fig.png"), "PNG bytes");
  EXPECT_EQ(names_in(dir_), std::vector<std::string>{"fig.png"});
}

TEST_F(AtomicFile, CommitFileFailureRemovesTheWrittenFile) {
  { std::ofstream(dir_ / "fig.png.part", std::ios::binary) << "PNG bytes"; }
  fs::create_directories(dir_ / "fig.png" / "inside");  // a non-empty folder cannot be replaced
  const auto e = error_of([&] { commit_file(dir_ / "fig.png.part", dir_ / "fig.png"); });
  ASSERT_TRUE(e) << "no alphainv::Error thrown";
  EXPECT_EQ(e->file(), (dir_ / "fig.png").string());
  EXPECT_NE(e->message().find("cannot rename"), std::string::npos) << e->what();
  EXPECT_EQ(names_in(dir_), std::vector<std::string>{"fig.png"});
  EXPECT_TRUE(fs::exists(dir_ / "fig.png" / "inside"));

  const auto missing = error_of([&] { commit_file(dir_ / "none.part", dir_ / "none.png"); });
  ASSERT_TRUE(missing) << "no alphainv::Error thrown";
  EXPECT_NE(missing->message().find("cannot open"), std::string::npos) << missing->what();
  EXPECT_FALSE(fs::exists(dir_ / "none.png"));
}

}  // namespace
}  // namespace alphainv::common
