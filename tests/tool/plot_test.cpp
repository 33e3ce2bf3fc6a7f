// Plots through gnuplot: the script says what the Plot says (closed checks on the text), a PNG of
// the requested size is drawn when gnuplot is installed, and a missing or failing gnuplot is one
// clear line.
#include "tool/plot.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/error.hpp"
#include "support/test_data.hpp"

namespace kneesim::tool {
namespace {

namespace fs = std::filesystem;

Plot makePlot(const std::string& file) {
  Plot p;
  p.file = file;
  p.title = "Knee \"force\"";
  p.xlabel = "gait cycle (%)";
  p.ylabel = "force (N)";
  p.series.push_back({"measured", {0, 50, 100}, {1, 2, 3}, "lines", "#000000"});
  PlotSeries s{"with a gap", {0, 25, 50, 75}, {1, NAN, 2, 4}, "lines", "", 2, 1.5};
  s.right_axis = true;
  p.series.push_back(s);
  p.hlines.push_back({1016, "paper"});
  p.vlines.push_back({64.5, "toe-off"});
  p.xmin = 0;
  p.xmax = 100;
  p.width = 320;
  p.height = 200;
  return p;
}

TEST(Plot, ScriptCarriesTheDataAndSettings) {
  const std::string s = makeGnuplotScript(makePlot("a.png"), "pngcairo", "a.png");
  EXPECT_NE(s.find("set terminal pngcairo size 320,200 noenhanced"), std::string::npos) << s;
  EXPECT_NE(s.find("set output \"a.png\""), std::string::npos);
  EXPECT_NE(s.find("set title \"Knee \\\"force\\\"\""), std::string::npos);  // quotes escaped
  EXPECT_NE(s.find("set xrange [0:100]"), std::string::npos);
  EXPECT_EQ(s.find("set yrange"), std::string::npos);  // not given: automatic
  EXPECT_NE(s.find("$d0 << EOD\n0 1\n50 2\n100 3\nEOD"), std::string::npos);
  // A non-finite point breaks the curve with a blank line.
  EXPECT_NE(s.find("$d1 << EOD\n0 1\n\n50 2\n75 4\nEOD"), std::string::npos) << s;
  EXPECT_NE(s.find("axes x1y2"), std::string::npos);
  EXPECT_NE(s.find("set y2tics"), std::string::npos);
  EXPECT_NE(s.find("first 1016"), std::string::npos);
  EXPECT_NE(s.find("first 64.5, graph 0"), std::string::npos);
  EXPECT_NE(s.find("title \"measured\""), std::string::npos);
}

TEST(Plot, MissingGnuplotIsReportedNotThrown) {
  const Gnuplot g = findGnuplot("/nonexistent/gnuplot");
  EXPECT_FALSE(g.isUsable());
  EXPECT_NE(g.problem.find("not found"), std::string::npos) << g.problem;
  AtomicFileSet out;
  try {
    renderPlots({makePlot("/tmp/never.png")}, g, out);
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot draw plots"), std::string::npos) << e.what();
  }
}

// Reads the width and height from a PNG's IHDR chunk.
std::pair<int, int> pngSize(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char b[24] = {};
  in.read(reinterpret_cast<char*>(b), 24);
  const auto be = [&](int i) { return (b[i] << 24) | (b[i + 1] << 16) | (b[i + 2] << 8) | b[i + 3]; };
  return {be(16), be(20)};
}

TEST(Plot, RendersPngsOfTheRequestedSize) {
  const Gnuplot g = findGnuplot();
  if (!g.isUsable()) GTEST_SKIP() << g.problem;
  std::printf("[ plot     ] %s, terminal %s\n", g.version.c_str(), g.terminal.c_str());
  const std::string dir = test::scratchDir("plot_render");
  {
    AtomicFileSet out;
    renderPlots({makePlot(dir + "/p/one.png")}, g, out);
    EXPECT_FALSE(fs::exists(dir + "/p/one.png"));  // staged, not yet written
    out.commit();
  }
  ASSERT_TRUE(fs::exists(dir + "/p/one.png"));
  EXPECT_EQ(pngSize(dir + "/p/one.png"), std::make_pair(320, 200));
  ASSERT_TRUE(fs::exists(dir + "/p/one.gp"));
  std::ifstream gp(dir + "/p/one.gp");
  const std::string script((std::istreambuf_iterator<char>(gp)), std::istreambuf_iterator<char>());
  EXPECT_NE(script.find("set output \"one.png\""), std::string::npos);  // re-renders beside itself

  // A gnuplot error (an unknown style) is one line naming the plot, and nothing is staged.
  Plot bad = makePlot(dir + "/bad.png");
  bad.series[0].style = "no-such-style";
  AtomicFileSet out;
  try {
    renderPlots({bad}, g, out);
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("gnuplot did not draw"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
  EXPECT_TRUE(out.getPaths().empty());
}

}  // namespace
}  // namespace kneesim::tool
