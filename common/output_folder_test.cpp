#include "common/output_folder.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace objscan {
namespace {
namespace fs = std::filesystem;

class OutputFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("objscan_output_folder_test_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }
  static void Write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }
  static std::string Read(const fs::path& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  fs::path root_;
};

TEST_F(OutputFolderTest, CreatesAMissingFolderWithItsParents) {
  std::string moved, error;
  ASSERT_TRUE(PrepareOutputFolder((root_ / "a/b/run").string(), &moved, &error)) << error;
  EXPECT_TRUE(fs::is_directory(root_ / "a/b/run"));
  EXPECT_TRUE(moved.empty());
}

TEST_F(OutputFolderTest, MovesAnEarlierRunAsideAndKeepsItWhole) {
  const fs::path run = root_ / "run";
  fs::create_directories(run / "logs");
  Write(run / "session.lcmlog", "first");
  Write(run / "model_mesh.ply", "first model");
  std::string moved, error;
  ASSERT_TRUE(PrepareOutputFolder(run.string() + "/", &moved, &error)) << error;
  EXPECT_EQ(moved, (root_ / "run.1").string());
  EXPECT_TRUE(fs::is_empty(run));
  EXPECT_EQ(Read(root_ / "run.1/session.lcmlog"), "first");
  EXPECT_EQ(Read(root_ / "run.1/model_mesh.ply"), "first model");
  // A third run: the second moves to the next free name, the first stays where it was.
  Write(run / "summary.json", "second");
  ASSERT_TRUE(PrepareOutputFolder(run.string(), &moved, &error)) << error;
  EXPECT_EQ(moved, (root_ / "run.2").string());
  EXPECT_EQ(Read(root_ / "run.1/session.lcmlog"), "first");
  EXPECT_EQ(Read(root_ / "run.2/summary.json"), "second");
}

TEST_F(OutputFolderTest, RefusesAFolderOfOtherFilesAndTouchesNothing) {
  const fs::path home = root_ / "home";
  fs::create_directories(home);
  Write(home / "notes.txt", "mine");
  std::string moved, error;
  EXPECT_FALSE(PrepareOutputFolder(home.string(), &moved, &error));
  EXPECT_NE(error.find("not an objscan output"), std::string::npos) << error;
  EXPECT_EQ(Read(home / "notes.txt"), "mine");
  EXPECT_FALSE(fs::exists(root_ / "home.1"));
}

TEST_F(OutputFolderTest, UsesAnEmptyFolderAndRefusesAFile) {
  fs::create_directories(root_ / "empty");
  std::string moved, error;
  EXPECT_TRUE(PrepareOutputFolder((root_ / "empty").string(), &moved, &error)) << error;
  EXPECT_TRUE(moved.empty());
  Write(root_ / "file", "x");
  EXPECT_FALSE(PrepareOutputFolder((root_ / "file").string(), &moved, &error));
  EXPECT_NE(error.find("not a folder"), std::string::npos) << error;
}

}  // namespace
}  // namespace objscan
