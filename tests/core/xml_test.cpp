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
