#include "cli/compare_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

#include "reports/canvas.hpp"
#include "model/verify.hpp"

namespace tensegrity::cli {

using reports::Canvas;
using reports::Colour;
using reports::TextAnchor;

namespace {

std::string g17(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string short_number(double v, const char* format = "%.3g") {
  char buf[40];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

// Distinct colours for the backends' lines (Tableau 10).
const Colour kSeriesColours[] = {{0.12, 0.47, 0.71}, {1.0, 0.5, 0.05},  {0.17, 0.63, 0.17},
                                 {0.84, 0.15, 0.16}, {0.58, 0.4, 0.74}, {0.55, 0.34, 0.29}};
const Colour kBlack{0, 0, 0}, kGrey{0.85, 0.85, 0.85}, kDarkGrey{0.3, 0.3, 0.3};

// A plot area with a log or linear axis per direction.
struct Axis {
  double lo, hi;  // data range (log10 of it when logarithmic)
  bool log;
  double to_unit(double v) const {
    const double t = log ? std::log10(std::max(v, std::pow(10.0, lo))) : v;
    return (t - lo) / (hi - lo);
  }
};

struct Panel {
  double x, y, w, h;  // px
  Axis ax, ay;
  double px(double v) const { return x + w * std::clamp(ax.to_unit(v), 0.0, 1.0); }
  double py(double v) const { return y + h * (1.0 - std::clamp(ay.to_unit(v), 0.0, 1.0)); }
};

Axis log_axis(double lo, double hi) {
  lo = std::floor(std::log10(lo));
  hi = std::ceil(std::log10(hi));
  if (hi <= lo) hi = lo + 1;
  return {lo, hi, true};
}

double nice_step(double span) {
  const double raw = span / 5.0, p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * p >= raw) return m * p;
  return 10 * p;
}

void draw_frame(Canvas& c, const Panel& p, const std::string& xlabel, const std::string& ylabel) {
  const double font = 13;
  if (p.ax.log) {
    for (int d = static_cast<int>(p.ax.lo); d <= static_cast<int>(p.ax.hi); ++d) {
      const double x = p.px(std::pow(10.0, d));
      c.line(x, p.y, x, p.y + p.h, kGrey, 1);
      c.text(x, p.y + p.h + 18, "1e" + std::to_string(d), font, kBlack, TextAnchor::Middle);
    }
  }
  if (p.ay.log) {
    const int step = std::max(1, static_cast<int>(std::ceil((p.ay.hi - p.ay.lo) / 8)));
    for (int d = static_cast<int>(p.ay.lo); d <= static_cast<int>(p.ay.hi); d += step) {
      const double y = p.py(std::pow(10.0, d));
      c.line(p.x, y, p.x + p.w, y, kGrey, 1);
      c.text(p.x - 6, y + 4, "1e" + std::to_string(d), font, kBlack, TextAnchor::End);
    }
  } else {
    const double step = nice_step(p.ay.hi - p.ay.lo);
    for (double v = 0; v <= p.ay.hi * (1 + 1e-9); v += step) {
      const double y = p.py(v);
      c.line(p.x, y, p.x + p.w, y, kGrey, 1);
      c.text(p.x - 6, y + 4, short_number(v, "%.3g"), font, kBlack, TextAnchor::End);
    }
  }
  c.rectangle_outline(p.x, p.y, p.w, p.h, kBlack, 1);
  c.text(p.x + p.w / 2, p.y + p.h + 38, xlabel, 14, kBlack, TextAnchor::Middle);
  c.text(p.x - 62, p.y + p.h / 2, ylabel, 14, kBlack, TextAnchor::Middle, 90);
}

}  // namespace

TracePoint start_point(const Structure& scene, const SolveOptions& options) {
  const SolveResult qp = solve_forces_only(scene, options);
  TracePoint p;
  if (qp.forces.size() == scene.num_elements() && qp.forces.allFinite()) {
    const Verification v = verify(scene, scene.positions, qp.forces, options.tolerance);
    p.residual = v.residual;
    p.relative_residual = v.relative_residual;
  } else {
    p.residual = p.relative_residual = std::nan("");
  }
  return p;
}

std::vector<TracePoint> normalised_trace(const std::vector<TracePoint>& trace, const TracePoint& start,
                                         const SolveResult& final_result) {
  std::vector<TracePoint> out{start};
  for (const TracePoint& p : trace)
    if (p.iteration > 0) out.push_back(p);
  TracePoint end;
  end.seconds = final_result.stats.seconds;
  end.iteration = std::max(final_result.stats.iterations, out.back().iteration);
  end.evaluations = out.back().evaluations;
  end.residual = final_result.stats.residual;
  end.relative_residual = final_result.stats.relative_residual;
  end.geometry_change = final_result.stats.geometry_change;
  end.objective = out.size() > 1 ? out.back().objective : 0.0;
  if (out.back().seconds < end.seconds) out.push_back(end);
  return out;
}

std::string compare_csv(const std::vector<CompareRow>& rows) {
  std::ostringstream o;
  o << "solver,status,seconds,iterations,relative_residual,geometry_change_m,largest_node_move_m,verified\n";
  for (const CompareRow& r : rows)
    o << r.solver << ',' << to_string(r.status) << ',' << g17(r.median_seconds) << ',' << r.iterations << ','
      << g17(r.relative_residual) << ',' << g17(r.geometry_change) << ',' << g17(r.largest_node_move) << ','
      << (r.verified ? "yes" : "no") << '\n';
  return o.str();
}

std::string compare_trace_csv(const std::vector<CompareRow>& rows) {
  std::ostringstream o;
  o << "solver,seconds,iteration,evaluations,residual,relative_residual,geometry_change,backend_objective\n";
  for (const CompareRow& r : rows)
    for (const TracePoint& p : r.trace)
      o << r.solver << ',' << g17(p.seconds) << ',' << p.iteration << ',' << p.evaluations << ','
        << g17(p.residual) << ',' << g17(p.relative_residual) << ',' << g17(p.geometry_change) << ','
        << g17(p.objective) << '\n';
  return o.str();
}

std::string compare_json(const std::string& scene_name, double tolerance, int repeat,
                         const std::vector<CompareRow>& rows) {
  nlohmann::json j;
  j["format"] = "tensegrity-compare";
  j["version"] = 1;
  j["scene"] = scene_name;
  j["tolerance"] = tolerance;
  j["repeat"] = repeat;
  j["rows"] = nlohmann::json::array();
  for (const CompareRow& r : rows)
    j["rows"].push_back({{"solver", r.solver},
                         {"status", std::string(to_string(r.status))},
                         {"message", r.message},
                         {"seconds", r.median_seconds},
                         {"iterations", r.iterations},
                         {"relative_residual", r.relative_residual},
                         {"geometry_change", r.geometry_change},
                         {"largest_node_move", r.largest_node_move},
                         {"verified", r.verified}});
  return j.dump(2) + "\n";
}

std::string compare_table(const std::vector<CompareRow>& rows) {
  std::ostringstream o;
  char buf[256];
  std::snprintf(buf, sizeof buf, "%-16s %-15s %10s %7s %11s %12s %12s %8s\n", "solver", "status", "seconds", "iters",
                "rel.resid", "geom.chg(m)", "max.move(m)", "verified");
  o << buf;
  for (const CompareRow& r : rows) {
    std::snprintf(buf, sizeof buf, "%-16s %-15s %10.4g %7d %11.3g %12.6g %12.6g %8s\n", r.solver.c_str(),
                  std::string(to_string(r.status)).c_str(), r.median_seconds, r.iterations, r.relative_residual,
                  r.geometry_change, r.largest_node_move, r.verified ? "yes" : "no");
    o << buf;
  }
  return o.str();
}

void write_compare_plot(const std::string& scene_name, const std::vector<CompareRow>& rows, const std::string& path) {
  constexpr int kWidth = 1000, kHeight = 820;
  double t_lo = 1e300, t_hi = 0, r_lo = 1e300, r_hi = 0, g_hi = 0;
  for (const CompareRow& r : rows)
    for (const TracePoint& p : r.trace) {
      if (p.seconds > 0) t_lo = std::min(t_lo, p.seconds), t_hi = std::max(t_hi, p.seconds);
      if (std::isfinite(p.relative_residual) && p.relative_residual > 0)
        r_lo = std::min(r_lo, p.relative_residual), r_hi = std::max(r_hi, p.relative_residual);
      if (std::isfinite(p.geometry_change)) g_hi = std::max(g_hi, p.geometry_change);
    }
  if (t_hi <= 0) t_lo = 1e-6, t_hi = 1;
  if (r_hi <= 0) r_lo = 1e-16, r_hi = 1;
  r_lo = std::max(r_lo, 1e-17);
  if (g_hi <= 0) g_hi = 1;
  const Axis time_axis = log_axis(t_lo, t_hi);
  const double left = 100, right = 190, top = 50, gap = 80, plot_h = (kHeight - top - gap - 60) / 2.0;
  const Panel upper{left, top, kWidth - left - right, plot_h, time_axis, log_axis(r_lo, r_hi)};
  const Panel lower{left, top + plot_h + gap, kWidth - left - right, plot_h, time_axis,
                    Axis{0, g_hi * 1.05, false}};
  Canvas c(kWidth, kHeight);
  c.text(left, 30, "compare: " + scene_name + " (start point at the left edge)", 16, kBlack);
  draw_frame(c, upper, "time (s)", "relative residual");
  draw_frame(c, lower, "time (s)", "geometry change (m)");
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const Colour colour = kSeriesColours[k % std::size(kSeriesColours)];
    std::vector<std::pair<double, double>> res, geo;
    for (const TracePoint& p : rows[k].trace) {
      if (std::isfinite(p.relative_residual)) res.emplace_back(upper.px(p.seconds), upper.py(p.relative_residual));
      if (std::isfinite(p.geometry_change)) geo.emplace_back(lower.px(p.seconds), lower.py(p.geometry_change));
    }
    c.set_attributes({{"data-solver", rows[k].solver}});
    c.polyline(res, colour, 2);
    c.polyline(geo, colour, 2);
    if (!res.empty()) c.circle(res.back().first, res.back().second, 4, colour);
    if (!geo.empty()) c.circle(geo.back().first, geo.back().second, 4, colour);
    c.clear_attributes();
    const double ly = top + 10 + 24 * k;
    c.line(kWidth - right + 15, ly, kWidth - right + 45, ly, colour, 3);
    c.text(kWidth - right + 52, ly + 5, rows[k].solver, 13, kBlack);
  }
  c.text(kWidth - right + 15, top + 20 + 24 * rows.size(), "dot: final, verified", 12, kDarkGrey);
  c.write(path);
}

}  // namespace tensegrity::cli
