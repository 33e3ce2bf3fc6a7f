#include "core/xml.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "support/memory_limit.hpp"
#include "support/test_data.hpp"

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

// 'first last step': the values are first + k step (not accumulated: 0.1 ten times is not 1.0, and
// the last value must still be there), and the count is checked before anything is made.
TEST(Xml, StepRangeValuesAndBounds) {
  auto doc = Document::parse("<r><a>0 1 0.1</a><b>-20 140 5</b><c>3 3 1</c><d>0 1e300 1e-300</d>"
                             "<e>1 0 1</e><f>0 nan 1</f><g>0 1 0</g><h>0 1</h></r>",
                             "r.xml");
  const std::vector<double> a = doc->root().child("a").toStepRange(100);
  ASSERT_EQ(a.size(), 11u);
  EXPECT_EQ(a[3], 3 * 0.1);
  EXPECT_DOUBLE_EQ(a[10], 1.0);
  const std::vector<double> b = doc->root().child("b").toStepRange(33);
  ASSERT_EQ(b.size(), 33u);
  EXPECT_EQ(b.front(), -20.0);
  EXPECT_EQ(b.back(), 140.0);
  EXPECT_EQ(doc->root().child("c").toStepRange(1), std::vector<double>{3.0});
  try {
    doc->root().child("b").toStepRange(32);
    FAIL() << "33 values passed a limit of 32";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "r.xml:1: r/b: expected at most 32 values, got 33 ('-20 140 5')");
  }
  for (const char* tag : {"d", "e", "f", "g", "h"}) EXPECT_THROW(doc->root().child(tag).toStepRange(1000000), InputError) << tag;
}

// An integer setting narrowed to int is range-checked first: 2^32 + 5 would wrap to 5.
TEST(Xml, IntInRangeRefusesWhatWouldWrap) {
  auto doc = Document::parse("<r><a>7</a><b>4294967301</b><c>0</c><d>7.5</d></r>", "r.xml");
  EXPECT_EQ(doc->root().child("a").toIntIn(1, 10), 7);
  try {
    doc->root().child("b").toIntIn(1, 2147483647);
    FAIL() << "2^32 + 5 passed";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "r.xml:1: r/b: expected an integer from 1 to 2147483647, got '4294967301'");
  }
  EXPECT_THROW(doc->root().child("c").toIntIn(1, 10), InputError);
  EXPECT_THROW(doc->root().child("d").toIntIn(1, 10), InputError);
}

TEST(Xml, SetupElementAsRootOrInsideOpenSimDocument) {
  auto bare = Document::parse("<MyTool name=\"t\"/>", "a.xml");
  EXPECT_EQ(requireSetupElement(*bare, "MyTool").nameAttr(), "t");
  auto wrapped = Document::parse("<OpenSimDocument>\n <MyTool name=\"u\"/>\n</OpenSimDocument>", "b.xml");
  const Node tool = requireSetupElement(*wrapped, "MyTool");
  EXPECT_EQ(tool.nameAttr(), "u");
  EXPECT_EQ(tool.line(), 2);
  try {
    requireSetupElement(*wrapped, "OtherTool");
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "b.xml:1: OpenSimDocument: no <OtherTool> element (expected it as the root or inside <OpenSimDocument>)");
  }
}

TEST(Xml, CheckChildrenNamesTheUnknownElementAndTheKnownOnes) {
  auto doc = Document::parse("<T>\n <b/>\n <a/>\n <c/>\n</T>", "c.xml");
  EXPECT_NO_THROW(checkChildren(doc->root(), {"a", "b", "c"}));
  try {
    checkChildren(doc->root(), {"b", "a"});
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "c.xml:4: T/c: unknown element <c> in <T> (expected one of a, b)");
  }
}

TEST(Xml, OpenSetupFileGivesItsFolderAndToolAndChecksTheChildren) {
  const std::string dir = test::scratchDir("xml_open_setup");
  const std::string path = dir + "/setup.xml";
  std::ofstream(path) << "<OpenSimDocument>\n <MyTool name=\"t\">\n  <a>1</a>\n  <z/>\n </MyTool>\n</OpenSimDocument>\n";
  const SetupFile f = openSetupFile(path, "MyTool", {"a", "z"});
  EXPECT_EQ(std::filesystem::path(f.dir), std::filesystem::path(dir));
  EXPECT_EQ(f.tool.nameAttr(), "t");
  EXPECT_EQ(f.tool.line(), 2);
  EXPECT_EQ(f.tool.child("a").toDouble(), 1.0);
  try {
    openSetupFile(path, "MyTool", {"a"});
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ":4: OpenSimDocument/MyTool[t]/z: unknown element <z> in <MyTool> (expected one of a)");
  }
  EXPECT_THROW(openSetupFile(dir + "/missing.xml", "MyTool", {}), InputError);
}

TEST(Xml, EscapeWritesTheFiveEntitiesAndParsesBack) {
  const std::string raw = "a&b <c> \"d\" 'e' f";
  EXPECT_EQ(escape(raw), "a&amp;b &lt;c&gt; &quot;d&quot; &apos;e&apos; f");
  EXPECT_EQ(escape(""), "");
  auto doc = Document::parse("<t v=\"" + escape(raw) + "\">" + escape(raw) + "</t>", "e.xml");
  EXPECT_EQ(*doc->root().attr("v"), raw);
  EXPECT_EQ(doc->root().text(), raw);
}

TEST(Xml, ResolvePathAgainstTheSetupFolder) {
  EXPECT_EQ(resolvePath("/data/setups", ""), "");
  EXPECT_EQ(resolvePath("/data/setups", "/abs/m.osim"), "/abs/m.osim");
  EXPECT_EQ(resolvePath("/data/setups", "../models/m.osim"), "/data/models/m.osim");
  EXPECT_EQ(resolvePath("/data/setups", "./a//b.trc"), "/data/setups/a/b.trc");
  EXPECT_EQ(resolvePath("", "m.osim"), "m.osim");
}

// XML entity expansion is bounded (issue 21 part 4): tinyxml2 expands only XML's five entities and
// character references, so a billion-laughs document's &lol9; stays the six characters it is
// instead of 3 GB. Read in a child process limited to 256 MB more than the test uses, so that a
// tinyxml2 that began expanding DTD entities fails this test instead of taking the machine's memory.
TEST(XmlFuzz, EntityExpansionIsBounded) {
  const std::string path = test::fixturePath("fixtures/billion-laughs.xml");
  const test::LimitedRun run = test::runWithMemoryLimit([&] {
    const auto doc = Document::load(path);
    return doc->root().nameAttr() + "|" + doc->root().child("value").text();
  });
  EXPECT_EQ(run.outcome, "returned");
  EXPECT_EQ(run.message, "&lol9;|&lol9;");
}

}  // namespace
}  // namespace kneesim::xml
