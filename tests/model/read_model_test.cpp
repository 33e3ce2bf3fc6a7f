// readModel() picks the reader by extension and names a missing file in one line.
#include "model/read_model.hpp"

#include <gtest/gtest.h>

#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim::model {
namespace {

TEST(ReadModel, PicksTheReaderByExtension) {
  EXPECT_EQ(readModel(test::sourcePath("tests/model/fixtures/chain.urdf"))->format_version, 0);  // URDF
  EXPECT_EQ(readModel(test::sourcePath("tests/model/fixtures/chain40000.osim"))->format_version, 40000);
  EXPECT_EQ(test::inputErrorOf([] { readModel("/nonexistent/m.osim"); }), "/nonexistent/m.osim: model file not found");
}

}  // namespace
}  // namespace kneesim::model
