#include "reports/naive_comparison_report.hpp"

#include <cstdio>

namespace tensegrity::reports {

namespace {

const char* method_name(SettleMethod m) { return m == SettleMethod::Relax ? "relax" : "simulate"; }

std::string row(const char* label, const Settling& s, const char* note) {
  char line[256];
  std::snprintf(line, sizeof line, "design:   %-16s %-14s %10.3g mm %10.3g %6d %s\n", label,
                std::string(to_string(s.status)).c_str(), 1e3 * s.max_displacement, s.relative_displacement,
                s.slack_cables, note);
  return line;
}

nlohmann::json settling_json(const Settling& s) {
  return {{"status", std::string(to_string(s.status))},
          {"message", s.message},
          {"max_displacement", s.max_displacement},
          {"max_displacement_node", s.max_displacement_node},
          {"relative_max_displacement", s.relative_displacement},
          {"size", s.size},
          {"slack_cables", s.slack_cables},
          {"cables_outside_measured_range", s.cables_outside_range},
          {"kinetic_energy", s.kinetic_energy},
          {"seconds", s.seconds}};
}

}  // namespace

std::string naive_comparison_table(const NaiveComparison& c, SettleMethod method) {
  std::string t = "design: settling under gravity (" + std::string(method_name(method)) +
                  ") from the designed shape; largest node displacement, also / size " +
                  std::to_string(c.designed.size) + " m\n";
  t += "design:   design           status          displacement   relative  slack\n";
  t += row("designed", c.designed, "");
  for (int k = 0; k < static_cast<int>(c.naive.size()); ++k) {
    const NaivePoint& p = c.naive[k];
    char label[64];
    std::snprintf(label, sizeof label, "naive F=%.4g", p.fraction);
    t += row(label, p.settling, !p.in_material_range ? "(strain outside the material)" : k == c.best ? "<- best" : "");
  }
  if (c.best >= 0) {
    const NaivePoint& b = c.naive[c.best];
    char line[512];
    std::snprintf(line, sizeof line,
                  "design: designed settles %.3g mm from its shape (%.3g of the size); the best naive fraction %.4g "
                  "settles %.3g mm away (%.3g of the size)\n",
                  1e3 * c.designed.max_displacement, c.designed.relative_displacement, b.fraction,
                  1e3 * b.settling.max_displacement, b.settling.relative_displacement);
    t += line;
  }
  return t;
}

nlohmann::json naive_comparison_json(const NaiveComparison& c, SettleMethod method) {
  nlohmann::json j = {{"format", "tensegrity-naive-comparison"},
                      {"version", 1},
                      {"method", method_name(method)},
                      {"designed", settling_json(c.designed)}};
  nlohmann::json naive = nlohmann::json::array();
  for (const NaivePoint& p : c.naive) {
    nlohmann::json e = settling_json(p.settling);
    e["fraction"] = p.fraction;
    e["in_material_range"] = p.in_material_range;
    naive.push_back(std::move(e));
  }
  j["naive"] = std::move(naive);
  if (c.best >= 0) j["best_fraction"] = c.naive[c.best].fraction;
  return j;
}

}  // namespace tensegrity::reports
