#include "momentum/plot/plot.hpp"

#include <sys/wait.h>

#include <algorithm>
#include <cctype>
#include <iterator>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"
#include "momentum/core/text.hpp"
#include "momentum/eval/truth.hpp"
#include "momentum/stream/reader.hpp"

namespace momentum::plot {

// Built on the detector's vocabulary (thresholds, motion states, events).
using namespace detect;

void check_gnuplot_text(std::string_view text, std::string_view what) {
  for (char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x20 || byte == 0x7f)
      throw Error(std::string(what) + " holds a control character (" +
                  (c == '\n' ? std::string("a newline") : c == '\r' ? std::string("a carriage return") : "byte " + std::to_string(byte)) +
                  "): '" + core::printable(text) + "'");
  }
}

std::string gnuplot_string(const std::string& text) {
  check_gnuplot_text(text, "text for gnuplot");
  std::string out = "'";
  for (char c : text) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

std::string plot_format(const std::string& output, const std::string& format) {
  static const char* const known[] = {"png", "svg", "pdf"};
  auto is_known = [](const std::string& name) { return std::find(std::begin(known), std::end(known), name) != std::end(known); };
  if (!format.empty() && !is_known(format)) throw Error("format must be png, svg or pdf, not '" + format + "'");
  const std::size_t slash = output.rfind('/');
  const std::string file = slash == std::string::npos ? output : output.substr(slash + 1);
  const std::size_t dot = file.rfind('.');
  std::string extension;
  if (dot != std::string::npos && dot > 0) extension = file.substr(dot + 1);
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (is_known(extension)) {
    if (!format.empty() && format != extension)
      throw Error("'" + core::printable(output, 4096) + "' names a " + extension + " file but --format is " + format);
    return extension;
  }
  if (!format.empty()) return format;
  if (extension.empty()) return "png";
  throw Error("cannot tell the image format of '" + core::printable(output, 4096) +
              "': name it .png, .svg or .pdf, or give --format");
}

std::string gnuplot_output(const PlotOptions& options, int height, const std::string& output) {
  const std::string size = std::to_string(options.width) + "," + std::to_string(height);
  std::string s;
  if (options.format == "svg") {
    s = "set terminal svg size " + size + " dynamic font 'Sans,11' background rgb 'white'\n";
  } else if (options.format == "pdf") {
    // pngcairo draws a point as one pixel: the same inches at 72 per inch give the PNG's layout.
    const std::string inches = core::significant(options.width / 72.0, 6) + "in," + core::significant(height / 72.0, 6) + "in";
    s = "if (strstrt(GPVAL_TERMINALS, 'pdfcairo') == 0) {\n  print 'this gnuplot cannot write pdf (no pdfcairo "
        "terminal): write .png or .svg'\n  exit status 1\n}\nset terminal pdfcairo size " +
        inches + " font 'Sans,10' background rgb 'white'\n";
  } else {
    s = "if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) {\n  set terminal pngcairo size " + size +
        " font 'Sans,10' background rgb 'white'\n} else {\n  set terminal png size " + size + "\n}\n";
  }
  return s + (output == "-" ? std::string("set output\n") : "set output " + gnuplot_string(output) + "\n");
}

bool PlotOptions::IsValid(std::string* why) const {
  if (format != "png" && format != "svg" && format != "pdf") return invalid(why, "format must be png, svg or pdf, not '" + format + "'");
  try {
    check_gnuplot_text(title, "the title");
  } catch (const Error& e) {
    return invalid(why, e.what());
  }
  if (width < kMinPlotWidth || width > kMaxPlotWidth) return invalid(why, "width must be 200..20000 pixels");
  if (panel_height < kMinPanelHeight || panel_height > kMaxPanelHeight) return invalid(why, "panel height must be 80..5000 pixels");
  if (max_points < kMinPlotPoints || max_points > kMaxPlotPoints) return invalid(why, "max points must be 10..100000");
  if (!(from < to)) return invalid(why, "the time window is empty (from >= to)");
  return true;
}

PlotData::PlotData(std::vector<Signal> signals, std::vector<std::optional<Thresholds>> thresholds, std::size_t joints,
                   bool have_velocity, PlotOptions options)
    : signals_(std::move(signals)), joints_(joints), have_velocity_(have_velocity), options_(std::move(options)) {
  std::string why;
  if (!options_.IsValid(&why)) throw Error(why);
  if (joints_ == 0 || signals_.empty()) throw Error("nothing to plot");
  if (thresholds.size() != signals_.size()) throw Error("one threshold set per signal");
  for (auto& t : thresholds) {
    if (t) {
      if (t->joints.size() != joints_)
        throw Error("thresholds for " + std::to_string(t->joints.size()) + " joints, the stream has " + std::to_string(joints_));
      DetectorOptions detector;
      detector.friction_band = options_.friction_band;
      detectors_.emplace_back(Detector(*t, detector, have_velocity_));
    } else {
      detectors_.emplace_back(std::nullopt);
    }
  }
}

void PlotData::add(double t, const double* const* x, const double* dq) {
  // mu's thresholds may judge rest on r: the plotted r then serves as mu's rest residual.
  const double* raw = nullptr;
  for (std::size_t s = 0; s < signals_.size(); ++s)
    if (signals_[s] == Signal::r) raw = x[s];
  for (std::size_t s = 0; s < signals_.size(); ++s)
    if (detectors_[s]) detectors_[s]->step(t, x[s], dq, signals_[s] == Signal::mu ? raw : nullptr);
  if (!(t >= options_.from && t <= options_.to)) return;
  ++rows_;
  if (buckets_.empty() || t - buckets_.back().t0 > width_ || (width_ == 0 && t != buckets_.back().t0)) {
    Bucket b;
    b.t0 = t;
    b.value.assign(signals_.size() * joints_, Range{});
    b.band.assign(signals_.size() * joints_, Range{-INFINITY, INFINITY});
    buckets_.push_back(std::move(b));
  }
  Bucket& b = buckets_.back();
  b.t1 = t;
  for (std::size_t s = 0; s < signals_.size(); ++s) {
    for (std::size_t j = 0; j < joints_; ++j) {
      const std::size_t k = series(s, j);
      const double v = x[s][j];
      if (std::isfinite(v)) {
        b.value[k].lo = std::min(b.value[k].lo, v);
        b.value[k].hi = std::max(b.value[k].hi, v);
      }
      if (detectors_[s]) {
        const auto& bound = detectors_[s]->bounds(j);
        // The band drawn is the narrowest of the bucket: every excursion out of it is visible.
        b.band[k].lo = std::max(b.band[k].lo, bound.lower);
        b.band[k].hi = std::min(b.band[k].hi, bound.upper);
      }
    }
  }
  if (buckets_.size() > 2 * options_.max_points) merge_pairs();
}

void PlotData::merge_pairs() {
  std::vector<Bucket> merged;
  merged.reserve(buckets_.size() / 2 + 1);
  for (std::size_t i = 0; i < buckets_.size(); i += 2) {
    Bucket b = std::move(buckets_[i]);
    if (i + 1 < buckets_.size()) {
      const Bucket& c = buckets_[i + 1];
      b.t1 = c.t1;
      for (std::size_t k = 0; k < b.value.size(); ++k) {
        b.value[k].lo = std::min(b.value[k].lo, c.value[k].lo);
        b.value[k].hi = std::max(b.value[k].hi, c.value[k].hi);
        b.band[k].lo = std::max(b.band[k].lo, c.band[k].lo);
        b.band[k].hi = std::min(b.band[k].hi, c.band[k].hi);
      }
    }
    merged.push_back(std::move(b));
  }
  buckets_ = std::move(merged);
  const double span = buckets_.back().t1 - buckets_.front().t0;
  width_ = std::max(2 * width_, span / static_cast<double>(options_.max_points));
}

std::string gnuplot_script(const PlotData& data, const std::vector<Event>& events,
                           const std::vector<eval::TruthContact>& truth, const std::string& output,
                           const PlotOptions& options) {
  const std::size_t n = data.joints(), columns = data.signals().size();
  const int height = static_cast<int>(n) * options.panel_height + (options.title.empty() ? 40 : 80);
  std::string s;
  s += "# momentum: residuals against thresholds\n";
  s += gnuplot_output(options, height, output);
  // Data blocks: residual as a min/max zig-zag per bucket, band as steps.
  const auto& buckets = data.buckets();
  for (std::size_t c = 0; c < columns; ++c) {
    for (std::size_t j = 0; j < n; ++j) {
      const std::size_t k = data.series(c, j);
      s += "$v" + std::to_string(c) + "_" + std::to_string(j) + " << EOD\n";
      for (const auto& b : buckets) {
        const auto& r = b.value[k];
        if (!(r.lo <= r.hi)) {
          s += "\n";  // no finite value in the bucket: a gap in the line
          continue;
        }
        s += core::exact(b.t0) + " " + core::exact(r.lo) + "\n";
        if (r.hi != r.lo || b.t1 != b.t0) s += core::exact(b.t1) + " " + core::exact(r.hi) + "\n";
      }
      s += "EOD\n";
      if (data.has_band(c)) {
        s += "$b" + std::to_string(c) + "_" + std::to_string(j) + " << EOD\n";
        for (const auto& b : buckets) {
          const auto& r = b.band[k];
          if (!std::isfinite(r.lo) || !std::isfinite(r.hi)) continue;
          s += core::exact(b.t0) + " " + core::exact(r.lo) + " " + core::exact(r.hi) + "\n";
        }
        if (!buckets.empty()) {
          const auto& r = buckets.back().band[k];
          if (std::isfinite(r.lo) && std::isfinite(r.hi))
            s += core::exact(buckets.back().t1) + " " + core::exact(r.lo) + " " + core::exact(r.hi) + "\n";
        }
        s += "EOD\n";
      }
    }
  }
  double t_min = INFINITY, t_max = -INFINITY;
  if (!buckets.empty()) t_min = buckets.front().t0, t_max = buckets.back().t1;
  if (std::isfinite(options.from)) t_min = options.from;
  if (std::isfinite(options.to)) t_max = options.to;
  const bool have_range = t_min < t_max;
  // Contacts shaded, events as vertical lines, in every panel.
  int object = 1;
  for (const auto& c : truth) {
    if (have_range && (c.t_end < t_min || c.t_onset > t_max)) continue;
    s += "set object " + std::to_string(object++) + " rect from " + core::exact(c.t_onset) + ", graph 0 to " + core::exact(c.t_end) +
         ", graph 1 back fc rgb '#c8ecc8' fs solid 1.0 noborder\n";
  }
  int arrow = 1;
  for (const auto& e : events) {
    if (have_range && (e.t_detect < t_min || e.t_detect > t_max)) continue;
    s += "set arrow " + std::to_string(arrow++) + " from " + core::exact(e.t_detect) + ", graph 0 to " + core::exact(e.t_detect) +
         ", graph 1 nohead front lc rgb '#d62728' lw 1.2 dt 2\n";
  }
  s += "set multiplot layout " + std::to_string(n) + "," + std::to_string(columns) +
       (options.title.empty() ? "" : " title " + gnuplot_string(options.title) + " font ',13'") + "\n";
  s += "set grid lc rgb '#dddddd'\nset ylabel 'Nm'\n";
  s += "set lmargin 10\nset rmargin 3\n";
  if (have_range) s += "set xrange [" + core::exact(t_min) + ":" + core::exact(t_max) + "]\n";
  for (std::size_t j = 0; j < n; ++j) {
    for (std::size_t c = 0; c < columns; ++c) {
      const Signal sig = data.signals()[c];
      std::string title = "joint " + std::to_string(j + 1) + ": " +
                          (sig == Signal::mu ? std::string("mu (friction compensated)")
                                             : std::string("r (no friction compensation)"));
      if (!data.has_band(c)) title += ", no thresholds";
      s += "set title " + gnuplot_string(title) + " font ',11'\n";
      s += j + 1 == n ? "set xlabel 't (s)'\n" : "unset xlabel\n";
      // Event labels (the isolated link) on the top row only.
      if (j == 0) {
        int label = 1;
        for (const auto& e : events) {
          if (have_range && (e.t_detect < t_min || e.t_detect > t_max)) continue;
          s += "set label " + std::to_string(label++) + " " + gnuplot_string("L" + std::to_string(e.link)) + " at " +
               core::exact(e.t_detect) + ", graph 1.04 center tc rgb '#d62728' font ',8'\n";
        }
        // The link each true contact was on, in the band's green, so that an isolation error
        // (red label differing from the green one) shows at a glance.
        for (const auto& c : truth) {
          if (have_range && (c.t_end < t_min || c.t_onset > t_max)) continue;
          s += "set label " + std::to_string(label++) + " " + gnuplot_string("L" + std::to_string(c.link)) + " at " +
               core::exact(c.t_onset) + ", graph 0.94 left front tc rgb '#2ca02c' font ',8'\n";
        }
      } else if (j == 1) {
        s += "unset label\n";
      }
      const bool key = j == 0 && c + 1 == columns;
      s += key ? "set key top right opaque box lc rgb '#bbbbbb' font ',9'\n" : "unset key\n";
      std::string v = "$v" + std::to_string(c) + "_" + std::to_string(j);
      std::string b = "$b" + std::to_string(c) + "_" + std::to_string(j);
      s += "plot " + v + " using 1:2 with lines lc rgb '#1f77b4' lw 1 " +
           (key ? std::string("title '") + (sig == Signal::mu ? "mu" : "r") + " (data)'" : std::string("notitle"));
      if (data.has_band(c)) {
        s += ", " + b + " using 1:3 with steps lc rgb '#ff7f0e' lw 1.5 " + (key ? "title 'threshold (steps: moving, slow, rest)'" : "notitle");
        s += ", " + b + " using 1:2 with steps lc rgb '#ff7f0e' lw 1.5 notitle";
      }
      if (key) {
        if (!truth.empty()) s += ", NaN with boxes fs solid 1.0 lc rgb '#c8ecc8' title 'true contact (green L: its link)'";
        if (!events.empty()) s += ", NaN with lines lc rgb '#d62728' dt 2 title 'detected (red L: isolated link)'";
      }
      s += "\n";
    }
  }
  s += "unset multiplot\nset output\n";
  return s;
}

void run_gnuplot(const std::string& script) {
  std::FILE* pipe = ::popen("gnuplot", "w");
  if (!pipe) throw Error(std::string("cannot run gnuplot: ") + std::strerror(errno));
  const std::size_t written = std::fwrite(script.data(), 1, script.size(), pipe);
  const int status = ::pclose(pipe);
  if (written != script.size() && status == 0) throw Error("gnuplot did not read the whole script");
  if (status == -1) throw Error(std::string("gnuplot: ") + std::strerror(errno));
  if (WIFEXITED(status) && WEXITSTATUS(status) == 127) throw Error("gnuplot not found (install gnuplot-nox)");
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) throw Error("gnuplot failed (its messages are above)");
}

}  // namespace momentum::plot
