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

TEST_F(OutputFolderTest, MarksResultFilesPartialInTheirHeaders) {
  std::string error;
  const std::string binary_body("\x01\x00\xff\n\x02", 5);
  Write(root_ / "model.ply",
        "ply\nformat binary_little_endian 1.0\ncomment units: mm\nelement vertex 1\nend_header\n" + binary_body);
  Write(root_ / "trajectory.txt", "# TUM trajectory: timestamp[s] tx ty tz qx qy qz qw\n# scale: metric\n0 1 2 3 0 0 0 1\n");
  Write(root_ / "plan.json", "{}\n");
  ASSERT_TRUE(MarkResultFilePartial((root_ / "model.ply").string(), "interrupted by SIGTERM", &error)) << error;
  ASSERT_TRUE(MarkResultFilePartial((root_ / "trajectory.txt").string(), "a process\nfailed", &error)) << error;
  EXPECT_EQ(Read(root_ / "model.ply"), "ply\nformat binary_little_endian 1.0\ncomment partial: interrupted by SIGTERM\n"
                                       "comment units: mm\nelement vertex 1\nend_header\n" + binary_body);
  EXPECT_EQ(Read(root_ / "trajectory.txt"),
            "# TUM trajectory: timestamp[s] tx ty tz qx qy qz qw\n# partial: a process failed\n# scale: metric\n"
            "0 1 2 3 0 0 0 1\n");
  // Marking twice changes nothing; a file of another kind is refused untouched.
  ASSERT_TRUE(MarkResultFilePartial((root_ / "model.ply").string(), "again", &error)) << error;
  EXPECT_EQ(Read(root_ / "model.ply").find("again"), std::string::npos);
  EXPECT_FALSE(MarkResultFilePartial((root_ / "plan.json").string(), "x", &error));
  EXPECT_EQ(Read(root_ / "plan.json"), "{}\n");
  EXPECT_FALSE(MarkResultFilePartial((root_ / "missing.ply").string(), "x", &error));
  EXPECT_FALSE(fs::exists(root_ / "model.ply.partial.tmp"));
}

}  // namespace
}  // namespace objscan
