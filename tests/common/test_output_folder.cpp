// Tests of src/common/output_folder.hpp: a whole output folder written beside the target and
// swapped into place. Before commit() the target is the old folder, untouched; after it the new
// one, with nothing of the old; without commit() nothing changes; a target holding files the
// command does not write is refused before any work; a killed process's sibling is cleaned up.
#include "common/output_folder.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "common/atomic_file.hpp"
#include "support/files.hpp"

namespace alphainv::common {
namespace {

namespace fs = std::filesystem;

using test::names_in;
using test::slurp;

class OutputFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_temp_dir("output_folder",
                                ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    out_ = dir_ / "fit";
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_, out_;
};

TEST_F(OutputFolderTest, TheTargetIsTheOldFolderUntilCommitThenTheNewOneWhole) {
  {
    OutputFolder first(out_, {"model.json", "report.md", "plots"});
    write_file_atomically(first.path() / "model.json", "old model");
    write_file_atomically(first.path() / "report.md", "old report");
    EXPECT_FALSE(fs::exists(out_));
    first.commit();
  }
  EXPECT_EQ(names_in(dir_), (std::vector<std::string>{"fit"}));
  {
    OutputFolder second(out_ / "", {"model.json", "report.md", "plots"});  // "fit/" names fit
    EXPECT_EQ(second.target(), out_);
    EXPECT_EQ(second.path().parent_path(), dir_);
    write_file_atomically(second.path() / "model.json", "new model");
    fs::create_directories(second.path() / "plots");
    EXPECT_EQ(slurp(out_ / "model.json"), "old model");  // untouched while the new one is written
    second.commit();
  }
  EXPECT_EQ(slurp(out_ / "model.json"), "new model");
  EXPECT_EQ(names_in(out_), (std::vector<std::string>{"model.json", "plots"}));  // no old report
  EXPECT_EQ(names_in(dir_), (std::vector<std::string>{"fit"}));                  // no sibling
}

TEST_F(OutputFolderTest, WithoutCommitTheTargetStaysAsItWas) {
  fs::create_directories(out_);
  write_file_atomically(out_ / "model.json", "good model");
  {
    OutputFolder failed(out_, {"model.json", "report.md"});
    write_file_atomically(failed.path() / "model.json", "partial");
  }  // a failed command: no commit()
  EXPECT_EQ(slurp(out_ / "model.json"), "good model");
  EXPECT_EQ(names_in(dir_), (std::vector<std::string>{"fit"}));
}

TEST_F(OutputFolderTest, AFolderOfOtherFilesIsRefusedBeforeAnyWork) {
  fs::create_directories(out_);
  write_file_atomically(out_ / "thesis.tex", "mine");
  try {
    OutputFolder refused(out_, {"model.json", "report.md"});
    ADD_FAILURE() << "a folder of other files was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.file(), out_.string());
    EXPECT_NE(std::string(e.what()).find("holds 'thesis.tex'"), std::string::npos) << e.what();
  }
  EXPECT_EQ(names_in(dir_), (std::vector<std::string>{"fit"}));
  write_file_atomically(dir_ / "file", "x");
  EXPECT_THROW(OutputFolder(dir_ / "file", {}), Error);
}

TEST_F(OutputFolderTest, ASiblingLeftByAKilledProcessIsRemoved) {
  const pid_t child = ::fork();
  if (child == 0) {  // writes into its sibling and is killed before commit()
    OutputFolder killed(out_, {"model.json"});
    write_file_atomically(killed.path() / "model.json", "half");
    ::_exit(0);  // no destructor: as SIGKILL leaves it
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_EQ(names_in(dir_).size(), 1u);  // the dead process's sibling
  EXPECT_EQ(names_in(dir_)[0].rfind(".fit.tmp." + std::to_string(child) + ".", 0), 0u);
  {
    OutputFolder next(out_, {"model.json"});
    EXPECT_EQ(names_in(dir_).size(), 1u);  // only next's own sibling
    next.commit();
  }
  EXPECT_EQ(names_in(dir_), (std::vector<std::string>{"fit"}));
}

}  // namespace
}  // namespace alphainv::common
