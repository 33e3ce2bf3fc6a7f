#include "core/atomic_file.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

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

}  // namespace
}  // namespace kneesim
