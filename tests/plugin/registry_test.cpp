#include "plugin/registry.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "identify/contact_law.hpp"
#include "support/test_data.hpp"
#include "support/input_error.hpp"

namespace kneesim::plugin {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

const std::string kBuildDir = KNEESIM_PLUGIN_BUILD_DIR;
const std::string kFixtureDir = KNEESIM_FIXTURE_PLUGIN_DIR;

using kneesim::test::inputErrorOf;

TEST(Registry, LoadsHertzByNameFromTheBuildFolder) {
  Registry r;
  r.loadPlugin("hertz");
  EXPECT_EQ(r.getContactLawNames(), (std::vector<std::string>{"hertz", "hertz_ml"}));
  const kneesim_contact_law& law = r.getContactLaw("hertz");
  EXPECT_STREQ(law.name, "hertz");
  EXPECT_EQ(law.n_params, 3);
  EXPECT_EQ(r.findOrigin("hertz"),
            std::filesystem::absolute(kBuildDir + "/libkneesim_hertz.so").lexically_normal().string());
  r.loadPlugin("hertz");  // a second load is a no-op, not a duplicate
  r.loadPlugin(kBuildDir + "/libkneesim_hertz.so");
  EXPECT_EQ(r.getContactLawNames().size(), 2u);
  r.loadPlugin("elastic_foundation");
  EXPECT_NE(r.findContactLaw("elastic_foundation"), nullptr);
}

TEST(Registry, MissingPluginIsOneLineNamingThePluginAndTheFolders) {
  Registry r;
  r.addSearchDirectory("/nonexistent/kneesim-plugins");
  const std::string msg =
      inputErrorOf([&] { r.loadPlugin("no_such_law", {"setup.xml", 12, "IdentifyTool/plugins/plugin"}); });
  EXPECT_THAT(msg, HasSubstr("setup.xml:12: IdentifyTool/plugins/plugin: no plugin 'no_such_law' found"));
  EXPECT_THAT(msg, HasSubstr("libkneesim_no_such_law.so"));
  EXPECT_THAT(msg, HasSubstr("/nonexistent/kneesim-plugins"));
  EXPECT_THAT(msg, HasSubstr(kBuildDir));
  EXPECT_THAT(msg, Not(HasSubstr("\n")));
  EXPECT_THAT(inputErrorOf([&] { r.loadPlugin("/nonexistent/libfoo.so"); }),
              HasSubstr("no plugin '/nonexistent/libfoo.so': the file does not exist"));
}

TEST(Registry, SearchPathComesFromTheEnvironmentBeforeTheBuildFolder) {
  const std::string dir = test::scratchDir("plugin_env");
  std::filesystem::copy_file(kBuildDir + "/libkneesim_hertz.so", dir + "/libkneesim_hertz.so");
  ASSERT_EQ(setenv("KNEESIM_PLUGIN_PATH", ("/nonexistent:" + dir).c_str(), 1), 0);
  Registry r;
  unsetenv("KNEESIM_PLUGIN_PATH");
  ASSERT_GE(r.getSearchDirectories().size(), 3u);
  EXPECT_EQ(r.getSearchDirectories()[0], "/nonexistent");
  EXPECT_EQ(r.getSearchDirectories()[1], dir);
  r.loadPlugin("hertz");
  EXPECT_EQ(r.findOrigin("hertz"), dir + "/libkneesim_hertz.so");
}

TEST(Registry, ALibraryThatIsNotAPluginIsRefused) {
  Registry r;
  const std::string msg = inputErrorOf([&] { r.loadPlugin(kFixtureDir + "/libnot_a_plugin.so", {"s.xml", 3, "p"}); });
  EXPECT_THAT(msg, HasSubstr("s.xml:3: p: '"));
  EXPECT_THAT(msg, HasSubstr("libnot_a_plugin.so' is not a kneesim plugin: it does not export kneesim_plugin_register"));
  // A file that is not a shared library at all.
  const std::string dir = test::scratchDir("plugin_text");
  std::ofstream(dir + "/libkneesim_text.so") << "not an ELF file\n";
  r.addSearchDirectory(dir);
  EXPECT_THAT(inputErrorOf([&] { r.loadPlugin("text"); }), HasSubstr("cannot load plugin '" + dir + "/libkneesim_text.so'"));
  EXPECT_TRUE(r.getContactLawNames().empty());
}

TEST(Registry, DuplicateLawNamesAreRefusedAndTheFirstIsKept) {
  Registry r;
  r.loadPlugin("hertz");
  const std::string first = r.findOrigin("hertz");
  const std::string msg = inputErrorOf([&] { r.loadPlugin(kFixtureDir + "/libdup_hertz.so"); });
  EXPECT_THAT(msg, HasSubstr("libdup_hertz.so' failed to register"));
  EXPECT_THAT(msg, HasSubstr("contact law 'hertz' is already registered by " + first));
  EXPECT_EQ(r.findOrigin("hertz"), first);
  EXPECT_EQ(r.getContactLaw("hertz").n_params, 3);  // still the real one, usable
}

TEST(Registry, ARefusedPluginLeavesNothingBehind) {
  Registry r;
  const std::string msg = inputErrorOf([&] { r.loadPlugin(kFixtureDir + "/libhalf_plugin.so"); });
  EXPECT_THAT(msg, HasSubstr("contact law 'half_bad': calc_force is NULL"));
  // half_good was registered before the failure; its table lived in the unloaded library.
  EXPECT_EQ(r.findContactLaw("half_good"), nullptr);
  EXPECT_TRUE(r.getContactLawNames().empty());
}

TEST(Registry, UnknownLawNameListsTheLoadedOnes) {
  Registry r;
  EXPECT_THAT(inputErrorOf([&] { r.getContactLaw("hertz"); }), HasSubstr("(loaded: none; is the plugin listed"));
  r.loadPlugin("hertz");
  r.loadPlugin("elastic_foundation");
  const std::string msg = inputErrorOf([&] { r.getContactLaw("hertzz", {"run.xml", 7, "ContactLaw"}); });
  EXPECT_EQ(msg, "run.xml:7: ContactLaw: no contact law named 'hertzz' (loaded: elastic_foundation, hertz, hertz_ml)");
}

int zeroForce(const double*, const kneesim_inputs* in, double* f, double*, char*, int) {
  for (int i = 0; i < in->n_frames; ++i) f[i] = 0;
  return 0;
}

TEST(Registry, InvalidTablesAreRefused) {
  static const kneesim_param bad_default[] = {{"k", "N", 0.0, 1.0, 2.0, 1.0, 0, "default above upper"}};
  static const kneesim_contact_law law = {sizeof(kneesim_contact_law), "bad", "", 1, bad_default, 0, nullptr,
                                          zeroForce, 0, nullptr, nullptr, nullptr};
  Registry r;
  try {
    r.adoptContactLaw(&law);
    FAIL() << "accepted a parameter whose default lies outside its bounds";
  } catch (const InternalError& e) {
    EXPECT_THAT(e.what(), HasSubstr("contact law 'bad': parameter 'k': expected lower <= default <= upper"));
  }
  kneesim_contact_law small = law;
  small.struct_size = 16;
  EXPECT_THROW(r.adoptContactLaw(&small), InternalError);
  EXPECT_TRUE(r.getContactLawNames().empty());
}

// Run by template_install_test.sh with the template plugin built against the installed package.
TEST(TemplatePlugin, LoadsAndComputes) {
  const char* path = std::getenv("KNEESIM_TEMPLATE_PLUGIN");
  if (!path) GTEST_SKIP() << "run by the plugin.template_install test (KNEESIM_TEMPLATE_PLUGIN not set)";
  Registry r;
  r.loadPlugin(path);
  const identify::ContactLaw law(r.getContactLaw("my_law"), r.findOrigin("my_law"));
  ASSERT_EQ(law.getNumParameters(), 2);
  EXPECT_EQ(law.getParameter(0).name, "p");
  EXPECT_TRUE(law.getParameter(1).fixed_by_default);
  const std::vector<double> time{0.0, 0.01, 0.02};
  const identify::ChannelMap channels{{"S", {0.0, 1e-4, 5e-4}}};
  const identify::LawInputs in(law, channels, time, "t");
  Eigen::VectorXd f;
  Eigen::MatrixXd df;
  law.calcForce(Eigen::Vector2d(3e6, 10.0), in, f, &df);
  // F = p S + F0 by hand: 10, 3e6 * 1e-4 + 10 = 310, 3e6 * 5e-4 + 10 = 1510.
  EXPECT_DOUBLE_EQ(f[0], 10.0);
  EXPECT_DOUBLE_EQ(f[1], 310.0);
  EXPECT_DOUBLE_EQ(f[2], 1510.0);
  EXPECT_DOUBLE_EQ(df(2, 0), 5e-4);
  EXPECT_DOUBLE_EQ(df(2, 1), 1.0);
}


// Run by template_install_test.sh: the template effect, built against the installed package.
TEST(TemplatePlugin, EffectLoadsAndIsNested) {
  const char* path = std::getenv("KNEESIM_TEMPLATE_EFFECT");
  if (!path) GTEST_SKIP() << "run by the plugin.template_install test (KNEESIM_TEMPLATE_EFFECT not set)";
  Registry r;
  r.loadPlugin(path);
  const kneesim_effect& e = r.getEffect("drift");
  ASSERT_EQ(e.n_params, 1);
  EXPECT_EQ(e.params[0].default_value, 0.0);
  const double time[] = {1.0, 1.5, 2.0}, base[] = {100, 200, 300}, tangent[] = {1, 2, 3};
  const char* names[] = {"time"};
  const double* values[] = {time};
  const kneesim_inputs in{3, 1, names, values};
  double force[3], tout[3], dforce[3];
  char err[128];
  // F = F_base + rate (t - t_first): at rate 0 the baseline, at rate 10 N/s +0, +5, +10 N by hand.
  const double zero = 0, ten = 10;
  ASSERT_EQ(e.map_force(&zero, &in, base, 1, tangent, force, tout, dforce, err, sizeof err), 0);
  EXPECT_EQ(force[2], 300.0);
  ASSERT_EQ(e.map_force(&ten, &in, base, 1, tangent, force, tout, dforce, err, sizeof err), 0);
  EXPECT_DOUBLE_EQ(force[1], 205.0);
  EXPECT_DOUBLE_EQ(force[2], 310.0);
  EXPECT_DOUBLE_EQ(dforce[2], 1.0);
  EXPECT_DOUBLE_EQ(tout[2], 3.0);
}

}  // namespace
}  // namespace kneesim::plugin
