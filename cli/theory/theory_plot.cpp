// gnuplot figures for the theory commands (see theory_plot.hpp).
#include "netkf/cli/theory/theory_plot.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include "netkf/cli/common/output_file.hpp"

namespace netkf::cli {
namespace {

std::string num(const std::optional<double>& v) {
  if (!v || !std::isfinite(*v)) return "NaN";
  std::ostringstream os;
  os.precision(10);
  os << *v;
  return os.str();
}

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

bool gnuplot_available() {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::stringstream dirs(path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    std::error_code ec;  // an entry that cannot be read is skipped, not fatal
    if (!dir.empty() && std::filesystem::exists(std::filesystem::path(dir) / "gnuplot", ec)) return true;
  }
  return false;
}

std::string terminal_for(const std::filesystem::path& out) {
  const std::string ext = out.extension().string();
  if (ext == ".png") return "set terminal pngcairo size 960,640 enhanced font 'sans,11'\n";
  if (ext == ".svg") return "set terminal svg size 960,640 enhanced font 'sans,11' background rgb 'white'\n";
  throw std::runtime_error("--plot: " + out.string() + ": use a .png or .svg file name");
}

/// Open the figure's file before gnuplot does: a path gnuplot cannot write would
/// otherwise end up as a figure on its standard output.
void check_writable(const std::filesystem::path& out) {
  std::error_code ec;
  const bool existed = std::filesystem::exists(out, ec);
  std::FILE* f = std::fopen(out.c_str(), "ab");
  if (!f) throw std::runtime_error("--plot: cannot write " + out.string() + ": " + std::strerror(errno));
  std::fclose(f);
  if (!existed) std::filesystem::remove(out, ec);  // leave nothing behind if the work fails later
}

void run_gnuplot(const std::string& script) {
  if (!gnuplot_available())
    throw std::runtime_error("--plot needs gnuplot on the PATH (Debian: apt-get install gnuplot-nox)");
  // gnuplot's standard output is never ours (it may carry --json): it goes nowhere.
  FILE* pipe = ::popen("gnuplot > /dev/null", "w");
  if (!pipe) throw std::runtime_error("--plot: could not start gnuplot");
  std::fwrite(script.data(), 1, script.size(), pipe);
  const int status = ::pclose(pipe);
  if (status != 0) throw std::runtime_error("--plot: gnuplot failed (exit status " + std::to_string(status) + ")");
}

}  // namespace

void check_plot_output(const std::filesystem::path& out) {
  terminal_for(out);
  check_output_path({"--plot", out.string()});  // a regular file only (output_file.hpp)
  check_writable(out);
}

namespace {

std::string header(const std::filesystem::path& out, const std::string& title) {
  std::string s = terminal_for(out);
  check_writable(out);
  s += "set output " + quoted(out.string()) + "\n";
  s += "set title " + quoted(title) + " noenhanced\n";
  s += "set grid\nset key top right\n";
  return s;
}

}  // namespace

void plot_sweep(const theory::AnalysisReport& report, const std::string& title, const std::filesystem::path& out) {
  std::ostringstream s;
  s << header(out, title);
  s << "$bounds << EOD\n";
  for (const auto& p : report.sweep) s << p.lambda << " " << num(p.lower_trace) << " " << num(p.upper_trace) << "\n";
  s << "EOD\n";
  s << "set xlabel 'arrival rate {/Symbol l}'\nset ylabel 'trace of the asymptotic E[P_{k|k-1}] bounds'\n";
  s << "set logscale y\nset xrange [0:1]\n";
  std::string marks;
  if (report.critical_rate) {
    const auto& cr = *report.critical_rate;
    s << "set arrow from " << cr.lower << ", graph 0 to " << cr.lower
      << ", graph 1 nohead dt 3 lc rgb '#444444'\n";
    s << "set label 'lower bound of {/Symbol l}_c = " << num(cr.lower) << "' at " << cr.lower
      << ", graph 0.95 offset 0.5,0 font ',9'\n";
    if (cr.upper && std::abs(*cr.upper - cr.lower) > 1e-3) {
      s << "set arrow from " << *cr.upper << ", graph 0 to " << *cr.upper
        << ", graph 1 nohead dt 2 lc rgb '#aa0000'\n";
      s << "set label 'upper bound (LMI) = " << num(cr.upper) << "' at " << *cr.upper
        << ", graph 0.88 offset 0.5,0 font ',9' tc rgb '#aa0000'\n";
    }
  }
  s << "plot $bounds using 1:3 with lines lw 2 lc rgb '#1f77b4' title 'Tr V-bar (upper bound, fixed point of g_{/Symbol l})', \\\n"
       "     $bounds using 1:2 with lines lw 2 dt 2 lc rgb '#2ca02c' title 'Tr S-bar (lower bound, Lyapunov)'\n";
  run_gnuplot(s.str());
}

void plot_region(const theory::AnalysisReport& report, const std::string& title, const std::filesystem::path& out) {
  std::ostringstream s;
  s << header(out, title);
  s << "$region << EOD\n";
  for (const auto& p : report.region) {
    const double upper = p.lambda2_upper.value_or(1.0);  // nothing stable: the whole column is not stable
    s << p.lambda1 << " " << p.lambda2_lower << " " << upper << " " << num(p.lambda2_exact) << "\n";
  }
  s << "EOD\n";
  s << "set xlabel '{/Symbol l}_1 (arrival rate of sensor 1)'\nset ylabel '{/Symbol l}_2 (arrival rate of sensor 2)'\n";
  s << "set xrange [0:1]\nset yrange [0:1]\nset key top right opaque box\nset size ratio -1\n";
  s << "plot $region using 1:3:(1) with filledcurves lc rgb '#b8e6b8' title 'stable (above the upper bound)', \\\n"
       "     $region using 1:(0):2 with filledcurves lc rgb '#f4b6b6' title 'unstable (below the lower bound)', \\\n"
       "     $region using 1:3 with lines lw 2 lc rgb '#1a7f1a' title 'upper bound of {/Symbol l}_{2c} (LMI)', \\\n"
       "     $region using 1:2 with lines lw 2 lc rgb '#b22222' title 'lower bound of {/Symbol l}_{2c} (Thm 3)', \\\n"
       "     $region using 1:4 with lines lw 2 dt 2 lc rgb 'black' title 'exact {/Symbol l}_{2c} (Markov criterion)'\n";
  run_gnuplot(s.str());
}

void plot_actuation_region(const theory::AnalysisReport& report, const std::string& title,
                           const std::filesystem::path& out) {
  const auto& region = *report.actuation_region;
  std::ostringstream s;
  s << header(out, title);
  s << "$region << EOD\n";
  for (const auto& p : region.points)
    s << p.gamma << " " << p.nu_lower << " " << p.nu_upper.value_or(1.0) << "\n";  // no stable ν̄: empty band
  s << "EOD\n";
  s << "set xlabel '{/Symbol g} (arrival rate of sensor " << region.sensor_id << ")'\n"
    << "set ylabel '{/Symbol n} (arrival rate of the control inputs)'\n";
  s << "set xrange [0:1]\nset yrange [0:1]\nset key top right opaque box\nset size ratio -1\n";
  s << "plot $region using 1:3:(1) with filledcurves lc rgb '#b8e6b8' title 'stable', \\\n"
       "     $region using 1:(0):2 with filledcurves lc rgb '#f4b6b6' title 'unstable', \\\n"
       "     $region using 1:2 with lines lw 2 lc rgb '#b22222' title 'unstable below', \\\n"
       "     $region using 1:3 with lines lw 2 dt 2 lc rgb '#1a7f1a' title 'stable above'\n";
  run_gnuplot(s.str());
}

void plot_monte_carlo(const MonteCarloResult& result, const theory::AnalysisReport& bounds, const std::string& title,
                      const std::filesystem::path& out) {
  std::ostringstream s;
  s << header(out, title);
  s << "$mc << EOD\n";
  for (const auto& p : result.series)
    s << p.step << " " << p.trace_P_pred.mean << " " << p.trace_P_pred.se << " " << p.sq_error_pred.mean << " "
      << p.sq_error_pred.se << "\n";
  s << "EOD\n";
  s << "set xlabel 'step k'\nset ylabel 'mean Tr P_{k|k-1} and mean squared error |x_k - xhat_{k|k-1}|^2' noenhanced\n";
  s << "set logscale y\n";
  s << "plot $mc using 1:($4-2*$5):($4+2*$5) with filledcurves lc rgb '#fdd0a2' title 'squared error: mean +/- 2 SE', \\\n"
       "     $mc using 1:4 with lines lc rgb '#e6550d' title 'mean squared error (" << result.runs << " runs)', \\\n"
       "     $mc using 1:($2-2*$3):($2+2*$3) with filledcurves lc rgb '#c6dbef' title 'Tr P: mean +/- 2 SE', \\\n"
       "     $mc using 1:2 with lines lw 2 lc rgb '#08519c' title 'mean Tr P_{k|k-1}'";
  if (bounds.upper_trace) s << ", \\\n     " << num(bounds.upper_trace) << " with lines dt 2 lw 2 lc rgb 'black' title 'Tr V-bar (upper bound)'";
  if (bounds.lower_trace) s << ", \\\n     " << num(bounds.lower_trace) << " with lines dt 3 lw 2 lc rgb '#2ca02c' title 'Tr S-bar (lower bound)'";
  s << "\n";
  run_gnuplot(s.str());
}

void plot_burst_histogram(const fit::LossFit& fit, const std::string& title, const std::filesystem::path& out) {
  std::ostringstream s;
  s << header(out, title);
  s << "$runs << EOD\n";
  for (const auto& b : fit.bursts.bins) {
    const std::string label = b.to < 0 ? std::to_string(b.from) + "+"
                              : b.from == b.to ? std::to_string(b.from)
                                               : std::to_string(b.from) + "-" + std::to_string(b.to);
    s << quoted(label) << " " << b.observed << " " << b.expected << "\n";
  }
  s << "EOD\n";
  s << "set xlabel 'burst length (consecutive drops)'\nset ylabel 'bursts'\n";
  s << "set style data histograms\nset style histogram clustered gap 1\nset style fill solid 0.8 border -1\n";
  s << "set yrange [0:*]\n";
  s << "plot $runs using 2:xtic(1) lc rgb '#1f77b4' title 'trace (" << fit.bursts.runs << " bursts)', \\\n"
       "     $runs using 3 lc rgb '#ff7f0e' title 'fitted " << fit::to_string(fit.family) << " (expected)' noenhanced\n";
  run_gnuplot(s.str());
}

}  // namespace netkf::cli
