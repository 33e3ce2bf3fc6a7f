// The checks a URDF passes before urdfdom reads it (engine/model/urdf_check.cpp): one-line errors with
// file and line, and every input urdfdom would leak or read otherwise refused before urdfdom runs.
#include "model/urdf_check.hpp"

#include <gtest/gtest.h>

#include <string>

#include "core/error.hpp"
#include "model/urdf.hpp"
#include "support/input_error.hpp"
#include "support/memory_limit.hpp"
#include "support/test_data.hpp"

namespace kneesim::model {
namespace {

std::string errorOf(const std::string& text) {
  try {
    parseUrdf(text, "bad.urdf");
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_EQ(w.find('\n'), std::string::npos);
    return w;
  }
  return "";
}

std::string robot(const std::string& joint) {
  return "<robot name=\"r\">\n<link name=\"a\"/>\n<link name=\"b\"/>\n" + joint + "</robot>\n";
}

TEST(Urdf, BadInputIsAOneLineErrorWithFileAndLine) {
  EXPECT_NE(errorOf("<robot name=\"r\"><link name=\"a\"></robot>").find("bad.urdf:1: malformed XML"), std::string::npos);
  const std::string unknown = errorOf(robot("<joint name=\"j\" type=\"hinge\"><parent link=\"a\"/><child link=\"b\"/></joint>\n"));
  EXPECT_NE(unknown.find("bad.urdf:4: robot[r]/joint[j]: unknown joint type 'hinge' (expected revolute"), std::string::npos)
      << unknown;
  const std::string planar = errorOf(robot("<joint name=\"j\" type=\"planar\"><parent link=\"a\"/><child link=\"b\"/></joint>\n"));
  EXPECT_NE(planar.find("unsupported joint type 'planar'"), std::string::npos) << planar;
  const std::string link = errorOf(robot("<joint name=\"j\" type=\"fixed\"><parent link=\"a\"/>\n<child link=\"c\"/></joint>\n"));
  EXPECT_NE(link.find("bad.urdf:5: "), std::string::npos) << link;
  EXPECT_NE(link.find("unknown child link 'c'"), std::string::npos) << link;
  const std::string number = errorOf(
      robot("<joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/>\n<origin xyz=\"0 x 0\"/></joint>\n"));
  EXPECT_NE(number.find("bad.urdf:5: "), std::string::npos) << number;
  EXPECT_NE(number.find("attribute 'xyz': expected a number, got 'x'"), std::string::npos) << number;
  const std::string limit = errorOf(robot("<joint name=\"j\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/></joint>\n"));
  EXPECT_NE(limit.find("expected a <limit> for a revolute joint"), std::string::npos) << limit;
  const std::string two_roots = errorOf(robot(""));
  EXPECT_NE(two_roots.find("urdfdom rejected the file"), std::string::npos) << two_roots;
  EXPECT_THROW(readUrdf("/nonexistent/robot.urdf"), InputError);
}

// Found by fuzzing (fuzz/, docs/fuzzing.md): urdfdom 3.0 leaks the shape it was reading when a
// geometry attribute does not parse (LeakSanitizer on fixtures/fuzz/urdf/box-size-bang.urdf). The
// reader now checks every attribute urdfdom reads, the way urdfdom reads it (a scalar is the whole
// attribute, a vector is split on spaces only), so urdfdom never sees one it cannot parse.
TEST(UrdfFuzz, GeometryAttributesUrdfdomCannotReadAreRefusedBeforeIt) {
  const std::string path = test::fixturePath("fixtures/fuzz/urdf/box-size-bang.urdf");
  try {
    readUrdf(path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ":3: robot[leak]/link[base]/visual/geometry/box: attribute 'size': "
                                            "expected a number, got '0.1!0.1'");
  }
  auto link = [](const std::string& geometry) {
    return "<robot name=\"r\">\n<link name=\"a\"><visual><geometry>" + geometry + "</geometry></visual></link>\n</robot>\n";
  };
  // Each of these passed the old checks (or had none) and failed inside urdfdom's parseGeometry.
  EXPECT_NE(errorOf(link("<sphere radius=\"0.1 \"/>")).find("attribute 'radius': expected a number, got '0.1 '"),
            std::string::npos);
  EXPECT_NE(errorOf(link("<box size=\"0.1\t0.1\t0.1\"/>")).find("attribute 'size': expected a number, got '0.1\t0.1\t0.1'"),
            std::string::npos);
  EXPECT_NE(errorOf(link("<cylinder radius=\"0.1\"/>")).find("bad.urdf:2: robot[r]/link[a]/visual/geometry/cylinder: "
                                                            "missing attribute 'length'"),
            std::string::npos);
  EXPECT_NE(errorOf(link("<mesh filename=\"m.stl\" scale=\"1 1 0x1\"/>")).find("attribute 'scale': expected a number, got '0x1'"),
            std::string::npos);
  EXPECT_NE(errorOf(link("<cone radius=\"1\"/>")).find("unknown geometry <cone> (expected box, cylinder, sphere or mesh)"),
            std::string::npos);
  // What urdfdom reads still reads.
  const ModelPtr m = parseUrdf(link("<box size=\" 0.1  0.2 0.3 \"/>"), "ok.urdf");
  ASSERT_EQ(m->ignored.size(), 1u);
  EXPECT_EQ(m->ignored[0].type, "visual box");
}

// Found by fuzzing: urdfdom links parent and child links by shared pointers both ways, so a joint
// loop leaks the whole model when urdfdom rejects it (LeakSanitizer on the fuzzer's input,
// fixtures/fuzz/urdf/joint-loop.urdf: joint j_pri from l2 to l2). Loops and links with two parent
// joints are refused before urdfdom sees them.
TEST(UrdfFuzz, JointLoopsAreRefusedBeforeUrdfdom) {
  const std::string path = test::fixturePath("fixtures/fuzz/urdf/joint-loop.urdf");
  EXPECT_NE(test::inputErrorOf([&] { readUrdf(path); })
                .find(path + ":49: robot[chain_urdf]/joint[j_pri]: expected a joint between two links, got 'l2' as "
                             "its parent and child"),
            std::string::npos);
  auto joint = [](const char* name, const char* parent, const char* child) {
    return std::string("<joint name=\"") + name + "\" type=\"fixed\"><parent link=\"" + parent + "\"/><child link=\"" + child +
           "\"/></joint>\n";
  };
  const std::string three = "<robot name=\"r\">\n<link name=\"a\"/>\n<link name=\"b\"/>\n<link name=\"c\"/>\n";
  EXPECT_NE(errorOf(three + joint("j1", "a", "b") + joint("j2", "b", "c") + joint("j3", "c", "b") + "</robot>\n")
                .find("robot[r]/joint[j3]: link 'b' is already the child of joint 'j1' (expected one parent joint per link)"),
            std::string::npos);
  EXPECT_NE(errorOf(three + joint("j1", "b", "c") + joint("j2", "c", "b") + "</robot>\n")
                .find("joint loop: link 'b' is its own ancestor (expected a tree of links)"),
            std::string::npos);
}

// Found by fuzzing: urdfdom's XML parser (TinyXML) drops an '&' that starts no entity, tinyxml2
// keeps it, so the link the checks knew as 'n&ertial' was not in urdfdom's model and the reader
// dereferenced a null link (UBSan on fixtures/fuzz/urdf/link-name-ampersand.urdf). Every name is
// now compared with what urdfdom read.
TEST(UrdfFuzz, NamesUrdfdomReadsDifferentlyAreOneLineErrors) {
  const std::string path = test::fixturePath("fixtures/fuzz/urdf/link-name-ampersand.urdf");
  const std::string msg = test::inputErrorOf([&] { readUrdf(path); });
  EXPECT_EQ(msg.rfind(path + ":5: ", 0), 0u) << msg;
  EXPECT_NE(msg.find(": urdfdom reads 'l1*>    n&ertial>' differently (its XML parser, TinyXML, drops an '&' that "
                     "starts no entity and reads some bytes otherwise): expected a name urdfdom reads as written"),
            std::string::npos)
      << msg;
  EXPECT_NE(errorOf(robot("<joint name=\"j&k\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>\n"))
                .find("bad.urdf:4: robot[r]/joint[j&k]: urdfdom reads 'j&k' differently"),
            std::string::npos);
  EXPECT_NE(errorOf("<robot name=\"r\">\n<link name=\"a\"/>\n<link name=\"b&c\"/>\n<link name=\"bc\"/>\n"
                    "<joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"b&c\"/></joint>\n</robot>\n")
                .find("bad.urdf:3: robot[r]/link[b&c]: urdfdom reads 'b&c' differently"),
            std::string::npos)
      << "urdfdom would read two links named 'bc'";
}

// Found by fuzzing (LeakSanitizer, fixtures/fuzz/urdf/parent-read-otherwise.urdf): bytes before a
// <parent> made TinyXML read joint j_rev otherwise than tinyxml2, urdfdom built a model the checks had
// not seen and leaked it; the names were compared only after urdfdom. TinyXML now reads the file first.
TEST(UrdfFuzz, NamesAreComparedWithUrdfdomsReadingBeforeUrdfdomBuildsAnything) {
  const std::string path = test::fixturePath("fixtures/fuzz/urdf/parent-read-otherwise.urdf");
  EXPECT_NE(test::inputErrorOf([&] { readUrdf(path); })
                .find(path + ":14: robot[chain_urdf]/joint[j_rev]/parent: urdfdom reads 'base' differently"),
            std::string::npos);
}

// Entity expansion is bounded in urdfdom's own XML parser (TinyXML) as well: a billion-laughs
// URDF is refused (TinyXML does not find the robot past the DTD) without expanding anything.
TEST(UrdfFuzz, BillionLaughsIsRefusedWithoutExpanding) {
  const std::string path = test::fixturePath("fixtures/fuzz/urdf/billion-laughs.urdf");
  const test::LimitedRun run = test::runWithMemoryLimit([&] { return readUrdf(path)->name; });
  EXPECT_EQ(run.outcome, "input error");
  EXPECT_EQ(run.message, path + ": robot: urdfdom rejected the file: Could not find the 'robot' element in the xml file");
}

}  // namespace
}  // namespace kneesim::model
