#include "core/xml.hpp"

#include <gtest/gtest.h>

namespace kneesim::xml {
namespace {

TEST(Xml, MalformedXmlNamesFileAndLine) {
  try {
    Document::parse("<a>\n<b>\n</a>", "bad.xml");
    FAIL() << "no throw";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("bad.xml:", 0), 0u) << what;
    EXPECT_EQ(e.getLocation().file, "bad.xml");
    EXPECT_GT(e.getLocation().line, 0);
    EXPECT_EQ(what.find('\n'), std::string::npos);
  }
}

TEST(Xml, ElementPathAndTypedReads) {
  auto doc = Document::parse("<Model name=\"m\">\n <Body name=\"femur\">\n  <mass> 7.5 </mass>\n"
                             "  <com>1 2 3</com>\n  <bad>x</bad>\n </Body>\n</Model>",
                             "m.osim");
  Node body = doc->root().child("Body");
  EXPECT_DOUBLE_EQ(body.child("mass").toDouble(), 7.5);
  EXPECT_EQ(body.child("com").toVec3(), Eigen::Vector3d(1, 2, 3));
  try {
    body.child("bad").toDouble();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "m.osim:5: Model[m]/Body[femur]/bad: expected a number, got 'x'");
  }
  EXPECT_THROW(body.child("com").toDouble(), InputError);
  EXPECT_THROW(body.requireChild("inertia"), InputError);
}

}  // namespace
}  // namespace kneesim::xml
