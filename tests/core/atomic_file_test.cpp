#include "core/atomic_file.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "support/test_data.hpp"

namespace kneesim {
namespace {

TEST(AtomicFile, NothingAppearsUntilCommit) {
  const std::string dir = test::scratchDir("atomic1");
  const std::string path = dir + "/out.txt";
  {
    AtomicFile f(path);
    f.stream() << "hello";
    EXPECT_FALSE(std::filesystem::exists(path));
    f.commit();
  }
  std::ifstream in(path);
  std::string s;
  in >> s;
  EXPECT_EQ(s, "hello");
}

TEST(AtomicFile, FailedWriterLeavesOldFileAndNoTemporary) {
  const std::string dir = test::scratchDir("atomic2");
  const std::string path = dir + "/out.txt";
  { std::ofstream(path) << "old"; }
  EXPECT_THROW(writeFileAtomically(path, [](std::ostream& os) {
                 os << "half";
                 throw InputError({"x", 0, ""}, "boom");
               }),
               InputError);
  std::ifstream in(path);
  std::string s;
  in >> s;
  EXPECT_EQ(s, "old");
  int n = 0;
  for (auto& e : std::filesystem::directory_iterator(dir)) { (void)e; ++n; }
  EXPECT_EQ(n, 1);
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

int countFiles(const std::string& dir) {
  int n = 0;
  for (auto& e : std::filesystem::directory_iterator(dir)) {
    (void)e;
    ++n;
  }
  return n;
}

TEST(AtomicFileSet, AllFilesAppearOnlyAtCommit) {
  const std::string dir = test::scratchDir("atomicset1");
  {
    AtomicFileSet set;
    set.add(dir + "/a.txt") << "alpha";
    set.addContents(dir + "/sub/b.txt", "beta");
    EXPECT_FALSE(std::filesystem::exists(dir + "/a.txt"));
    EXPECT_FALSE(std::filesystem::exists(dir + "/sub/b.txt"));
    set.commit();
    EXPECT_EQ(set.getPaths(), (std::vector<std::string>{dir + "/a.txt", dir + "/sub/b.txt"}));
  }
  EXPECT_EQ(slurp(dir + "/a.txt"), "alpha");
  EXPECT_EQ(slurp(dir + "/sub/b.txt"), "beta");
  EXPECT_EQ(countFiles(dir), 2);  // a.txt and sub/, no temporaries or backups left
}

TEST(AtomicFileSet, UncommittedSetLeavesTargetsUntouchedAndNoTemporaries) {
  const std::string dir = test::scratchDir("atomicset2");
  { std::ofstream(dir + "/a.txt") << "old"; }
  {
    AtomicFileSet set;
    set.addContents(dir + "/a.txt", "new");
    set.addContents(dir + "/b.txt", "new");
  }  // e.g. an exception after staging
  EXPECT_EQ(slurp(dir + "/a.txt"), "old");
  EXPECT_FALSE(std::filesystem::exists(dir + "/b.txt"));
  EXPECT_EQ(countFiles(dir), 1);
}

TEST(AtomicFileSet, FailedRenameRollsBackTheFilesAlreadyPlaced) {
  const std::string dir = test::scratchDir("atomicset3");
  { std::ofstream(dir + "/a.txt") << "old"; }
  // The second target is an existing non-empty folder: renaming a file onto it fails.
  std::filesystem::create_directories(dir + "/b.txt/inside");
  AtomicFileSet set;
  set.addContents(dir + "/a.txt", "new");
  set.addContents(dir + "/b.txt", "new");
  set.addContents(dir + "/c.txt", "new");
  try {
    set.commit();
    FAIL() << "commit should fail";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(dir + "/b.txt"), std::string::npos) << e.what();
  }
  EXPECT_EQ(slurp(dir + "/a.txt"), "old");  // restored
  EXPECT_TRUE(std::filesystem::is_directory(dir + "/b.txt"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/c.txt"));
  EXPECT_EQ(countFiles(dir), 2);  // a.txt and the b.txt folder only
}

TEST(AtomicFileSet, TheSameTargetTwiceIsAnError) {
  const std::string dir = test::scratchDir("atomicset4");
  AtomicFileSet set;
  set.addContents(dir + "/a.txt", "1");
  EXPECT_THROW(set.addContents(dir + "/./a.txt", "2"), InputError);
}

}  // namespace
}  // namespace kneesim
