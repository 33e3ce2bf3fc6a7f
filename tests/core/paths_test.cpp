#include "core/paths.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim {
namespace {

// A name longer than the system allows (NAME_MAX 255 here) makes the throwing
// std::filesystem::exists throw filesystem_error ("File name too long"); pathExists says no.
TEST(Paths, ANameTooLongDoesNotExistInsteadOfThrowing) {
  const std::string dir = test::scratchDir("paths_exists");
  const std::string too_long = dir + "/" + std::string(300, 'a') + ".osim";
  EXPECT_THROW((void)std::filesystem::exists(too_long), std::filesystem::filesystem_error);  // why the helper exists
  EXPECT_FALSE(pathExists(too_long));
  EXPECT_TRUE(pathExists(dir));
  EXPECT_FALSE(pathExists(dir + "/missing.osim"));
}

// A folder under a regular file cannot be made: a one-line InputError naming the folder.
TEST(Paths, AFolderThatCannotBeMadeIsAnInputErrorNamingIt) {
  const std::string dir = test::scratchDir("paths_folder");
  std::ofstream(dir + "/file") << "x";
  const std::string msg = test::inputErrorOf([&] { createFolder(dir + "/file/results"); });
  EXPECT_EQ(msg.rfind(dir + "/file/results: cannot create folder: ", 0), 0u) << msg;
  EXPECT_EQ(msg.find('\n'), std::string::npos);
  EXPECT_NE(test::inputErrorOf([&] { createFolder(dir + "/" + std::string(300, 'b')); }).find("cannot create folder"),
            std::string::npos);
  createFolder(dir + "/a/b/c");
  EXPECT_TRUE(std::filesystem::is_directory(dir + "/a/b/c"));
  createFolder(dir + "/a/b/c");  // an existing folder is fine
}

}  // namespace
}  // namespace kneesim
