#pragma once
// Line plots as PNG files drawn by gnuplot (Debian package gnuplot-nox: no X needed, terminal
// pngcairo, else png). Each plot becomes a self-contained gnuplot script with its data inline, so a
// user can edit and re-render it; the engine runs gnuplot on a copy in a temporary folder and
// stages the PNG (and, on request, the script) in an AtomicFileSet.

#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/atomic_file.hpp"

namespace kneesim::tool {

/// One curve of a plot. Points with a non-finite x or y break the line.
struct PlotSeries {
  std::string title;                ///< Legend entry ("" for none).
  std::vector<double> x, y;
  std::string style = "lines";      ///< gnuplot's "with" clause: "lines", "points", "linespoints".
  std::string color;                ///< e.g. "#1f77b4"; "" for gnuplot's sequence.
  int dash = 0;                     ///< gnuplot dash type (0: solid).
  double width = 2.0;               ///< Line width.
  bool right_axis = false;          ///< Plot against the right y axis (y2).
};

/// A reference line across the plot.
struct PlotLine {
  double value = 0;
  std::string label;
  std::string color = "#555555";
};

/// A 2-D line plot.
struct Plot {
  std::string file;  ///< Final PNG path.
  std::string title, xlabel, ylabel, y2label;
  std::vector<PlotSeries> series;
  std::vector<PlotLine> hlines;  ///< Horizontal lines (y values on the left axis).
  std::vector<PlotLine> vlines;  ///< Vertical lines (x values).
  double xmin = std::numeric_limits<double>::quiet_NaN(), xmax = std::numeric_limits<double>::quiet_NaN();
  double ymin = std::numeric_limits<double>::quiet_NaN(), ymax = std::numeric_limits<double>::quiet_NaN();
  int width = 900, height = 540;  ///< Pixels.
};

/// A gnuplot found on the system and the PNG terminal it offers.
struct Gnuplot {
  std::string executable;  ///< As given (a name looked up in PATH, or a path).
  std::string terminal;    ///< "pngcairo" or "png"; "" when unusable.
  std::string version;     ///< e.g. "gnuplot 5.4 patchlevel 4".
  std::string problem;     ///< Why it is unusable ("" when usable).
  bool isUsable() const { return problem.empty(); }
};

/// Looks for @p executable and asks it for its terminals (pngcairo preferred, else png). Never
/// throws: a missing program or one without a PNG terminal is reported in Gnuplot::problem.
Gnuplot findGnuplot(const std::string& executable = "gnuplot");

/// The gnuplot script of @p plot writing @p output_png with @p terminal (data inline).
std::string makeGnuplotScript(const Plot& plot, const std::string& terminal, const std::string& output_png);

/// Renders every plot with @p gnuplot into a temporary folder and stages the PNGs at their
/// Plot::file in @p outputs; with @p with_scripts also the script beside each PNG (same name,
/// .gp, writing the PNG's file name relative to the script's folder). Throws InputError naming the
/// plot if gnuplot is unusable or fails (its message in one line).
void renderPlots(const std::vector<Plot>& plots, const Gnuplot& gnuplot, AtomicFileSet& outputs,
                 bool with_scripts = true);

}  // namespace kneesim::tool
