#include "tool/plot.hpp"

#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include <sys/wait.h>

#include "core/error.hpp"
#include "core/paths.hpp"
#include "core/strings.hpp"

namespace kneesim::tool {

namespace fs = std::filesystem;

namespace {

// @p s as a gnuplot double-quoted string.
std::string gpString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c == '\n' ? ' ' : c;
  }
  return out + "\"";
}

// Runs @p command through the shell; returns its exit status (-1 if it could not run) and fills
// @p output with its standard output and error.
int runCommand(const std::string& command, std::string& output) {
  output.clear();
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (!p) return -1;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) output.append(buf, n);
  const int status = pclose(p);
  if (status == -1) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string oneLine(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r' || c == '\t') c = ' ';
  s = std::string(trim(s));
  if (s.size() > 400) s = s.substr(0, 400) + "...";
  return s;
}

std::string number(double v) {
  std::ostringstream os;
  os << std::setprecision(9) << v;
  return os.str();
}

}  // namespace

Gnuplot findGnuplot(const std::string& executable) {
  Gnuplot g;
  g.executable = executable;
  std::string out;
  const int rc = runCommand(shellQuote(executable) +
                                " -e \"print GPVAL_TERMINALS; print sprintf('gnuplot %g patchlevel %s', "
                                "GPVAL_VERSION, GPVAL_PATCHLEVEL)\"",
                            out);
  if (rc != 0) {
    g.problem = rc == 127 ? "'" + executable + "' was not found (install the Debian package gnuplot-nox)"
                          : "'" + executable + "' failed (exit status " + std::to_string(rc) + "): " + oneLine(out);
    return g;
  }
  bool cairo = false, png = false;
  for (std::string_view w : splitWhitespace(out)) {
    cairo = cairo || w == "pngcairo";
    png = png || w == "png";
  }
  const size_t v = out.find("gnuplot ");
  if (v != std::string::npos) g.version = oneLine(out.substr(v, out.find('\n', v) - v));
  if (cairo)
    g.terminal = "pngcairo";
  else if (png)
    g.terminal = "png";
  else
    g.problem = "'" + executable + "' offers no PNG terminal (pngcairo or png)";
  return g;
}

std::string makeGnuplotScript(const Plot& plot, const std::string& terminal, const std::string& output_png) {
  std::ostringstream s;
  s << "# " << plot.title << "\n# Drawn by kneesim; re-render with: gnuplot <this file>\n";
  s << "set terminal " << terminal << " size " << plot.width << "," << plot.height << " noenhanced"
    << (terminal == "pngcairo" ? " font 'Sans,11'" : "") << "\n";
  s << "set output " << gpString(output_png) << "\n";
  s << "set title " << gpString(plot.title) << "\n";
  s << "set xlabel " << gpString(plot.xlabel) << "\n";
  s << "set ylabel " << gpString(plot.ylabel) << "\n";
  bool right = false;
  for (const PlotSeries& ser : plot.series) right = right || ser.right_axis;
  if (right) s << "set y2label " << gpString(plot.y2label) << "\nset y2tics\nset ytics nomirror\n";
  s << "set grid\nset key top right opaque box\nset datafile missing 'NaN'\n";
  const auto range = [&](const char* axis, double lo, double hi) {
    if (std::isfinite(lo) || std::isfinite(hi))
      s << "set " << axis << "range [" << (std::isfinite(lo) ? number(lo) : "*") << ":"
        << (std::isfinite(hi) ? number(hi) : "*") << "]\n";
  };
  range("x", plot.xmin, plot.xmax);
  range("y", plot.ymin, plot.ymax);
  for (const PlotLine& l : plot.hlines) {
    s << "set arrow from graph 0, first " << number(l.value) << " to graph 1, first " << number(l.value)
      << " nohead dt 2 lw 1.5 lc rgb " << gpString(l.color) << "\n";
    if (!l.label.empty())
      s << "set label " << gpString(l.label) << " at graph 0.01, first " << number(l.value)
        << " offset 0,0.6 tc rgb " << gpString(l.color) << "\n";
  }
  for (const PlotLine& l : plot.vlines) {
    s << "set arrow from first " << number(l.value) << ", graph 0 to first " << number(l.value)
      << ", graph 1 nohead dt 3 lw 1.5 lc rgb " << gpString(l.color) << "\n";
    if (!l.label.empty())
      s << "set label " << gpString(l.label) << " at first " << number(l.value)
        << ", graph 0.04 offset 0.5,0 tc rgb " << gpString(l.color) << "\n";
  }
  for (size_t k = 0; k < plot.series.size(); ++k) {
    const PlotSeries& ser = plot.series[k];
    s << "$d" << k << " << EOD\n";
    bool broken = true;
    for (size_t i = 0; i < ser.x.size() && i < ser.y.size(); ++i) {
      if (!std::isfinite(ser.x[i]) || !std::isfinite(ser.y[i])) {
        if (!broken) s << "\n";  // a blank line breaks the curve
        broken = true;
        continue;
      }
      s << number(ser.x[i]) << " " << number(ser.y[i]) << "\n";
      broken = false;
    }
    s << "EOD\n";
  }
  if (plot.series.empty()) {
    s << "plot NaN notitle\n";
    return s.str();
  }
  s << "plot ";
  for (size_t k = 0; k < plot.series.size(); ++k) {
    const PlotSeries& ser = plot.series[k];
    s << (k == 0 ? "" : ", \\\n     ") << "$d" << k << " using 1:2 with " << ser.style << " lw " << number(ser.width);
    if (ser.dash > 0) s << " dt " << ser.dash;
    if (!ser.color.empty()) s << " lc rgb " << gpString(ser.color);
    if (ser.right_axis) s << " axes x1y2";
    s << (ser.title.empty() ? std::string(" notitle") : " title " + gpString(ser.title));
  }
  s << "\n";
  return s.str();
}

void renderPlots(const std::vector<Plot>& plots, const Gnuplot& gnuplot, AtomicFileSet& outputs, bool with_scripts) {
  if (plots.empty()) return;
  if (!gnuplot.isUsable()) throw InputError({plots.front().file, 0, "plot"}, "cannot draw plots: " + gnuplot.problem);
  static std::atomic<int> counter{0};
  const fs::path tmp = fs::temp_directory_path() /
                       ("kneesim_plot_" + std::to_string(getpid()) + "_" + std::to_string(counter++));
  createFolder(tmp);
  struct Cleanup {
    fs::path p;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(p, ec);
    }
  } cleanup{tmp};
  for (size_t k = 0; k < plots.size(); ++k) {
    const Plot& plot = plots[k];
    const fs::path png = tmp / ("plot" + std::to_string(k) + ".png");
    const fs::path script = tmp / ("plot" + std::to_string(k) + ".gp");
    {
      std::ofstream out(script);
      out << makeGnuplotScript(plot, gnuplot.terminal, png.string());
      if (!out) throw InputError({script.string(), 0, "plot"}, "could not write the gnuplot script");
    }
    std::string message;
    const int rc = runCommand(shellQuote(gnuplot.executable) + " " + shellQuote(script.string()), message);
    std::string bytes;
    {
      std::ifstream in(png, std::ios::binary);
      bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    if (rc != 0 || bytes.size() < 8 || bytes.compare(0, 4, "\x89PNG") != 0)
      throw InputError({plot.file, 0, "plot"}, "gnuplot did not draw '" + plot.title + "' (exit status " +
                                                   std::to_string(rc) + "): " + oneLine(message));
    outputs.addContents(plot.file, bytes, true);
    if (with_scripts) {
      const fs::path final_png(plot.file);
      outputs.addContents(fs::path(plot.file).replace_extension(".gp").string(),
                          makeGnuplotScript(plot, gnuplot.terminal, final_png.filename().string()));
    }
  }
}

}  // namespace kneesim::tool
