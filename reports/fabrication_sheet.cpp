#include "reports/fabrication_sheet.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <sstream>
#include <vector>

#include "reports/canvas.hpp"
#include "reports/exporters.hpp"

namespace tensegrity::reports {

namespace {

constexpr double kMillimetresPerMetre = 1000.0;

// Block and link groups in assembly order: blocks first, then links, each in
// the order they first appear; elements without an id last.
struct AssemblyGroup {
  std::string kind, id;
  std::vector<int> elements;
};

std::string group_id_text(const nlohmann::json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); }

std::vector<AssemblyGroup> assembly_groups(const Structure& s) {
  std::vector<AssemblyGroup> blocks, links;
  AssemblyGroup rest{"none", "", {}};
  auto find_or_add = [](std::vector<AssemblyGroup>& groups, const std::string& kind,
                        const std::string& id) -> AssemblyGroup& {
    for (auto& g : groups)
      if (g.id == id) return g;
    groups.push_back(AssemblyGroup{kind, id, {}});
    return groups.back();
  };
  for (int e = 0; e < s.num_elements(); ++e) {
    const nlohmann::json extra =
        e < static_cast<int>(s.element_extra.size()) ? s.element_extra[e] : nlohmann::json::object();
    if (extra.contains("block")) find_or_add(blocks, "block", group_id_text(extra.at("block"))).elements.push_back(e);
    else if (extra.contains("link")) find_or_add(links, "link", group_id_text(extra.at("link"))).elements.push_back(e);
    else rest.elements.push_back(e);
  }
  std::vector<AssemblyGroup> out = blocks;
  out.insert(out.end(), links.begin(), links.end());
  if (!rest.elements.empty()) out.push_back(rest);
  // Within a group: struts (cut from tube) before cables, each in element order.
  for (auto& g : out)
    std::stable_sort(g.elements.begin(), g.elements.end(), [&](int a, int b) {
      return (s.elements[a].kind == ElementKind::Strut) > (s.elements[b].kind == ElementKind::Strut);
    });
  return out;
}

std::string csv_field(const std::string& v) {
  if (v.find_first_of(",\"\n") == std::string::npos) return v;
  std::string q = "\"";
  for (char c : v) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

std::string sheet_number(double v, const char* format) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}
std::string millimetres(double metres) { return sheet_number(metres * kMillimetresPerMetre, "%.1f"); }

}  // namespace

std::string fabrication_sheet_csv(const Design& d, const Eigen::VectorXd& lengths) {
  const Structure& s = d.structure;
  std::ostringstream out;
  out << "group_kind,group,element,name,kind,node_a,node_b,material,length_mm,rest_length_mm,force_N,strain,count\n";
  int struts = 0;
  double strut_length = 0.0;
  std::map<std::string, std::pair<int, std::pair<double, double>>> per_material;  // count, (l, L)
  for (const AssemblyGroup& g : assembly_groups(s)) {
    for (int e : g.elements) {
      const bool strut = s.elements[e].kind == ElementKind::Strut;
      const double L = (*d.solution.rest_lengths)[e];
      out << g.kind << ',' << csv_field(g.id) << ',' << e << ',' << csv_field(element_name(s, e)) << ','
          << (strut ? "strut" : "cable") << ',' << s.elements[e].a << ',' << s.elements[e].b << ','
          << csv_field(d.cable_material[e]) << ',' << millimetres(lengths[e]) << ',' << millimetres(L) << ','
          << sheet_number(d.solution.forces[e], "%.3g") << ',' << sheet_number(d.strains[e], "%.4f") << ",1\n";
      if (strut) {
        ++struts;
        strut_length += lengths[e];
      } else {
        auto& t = per_material[d.cable_material[e]];
        ++t.first;
        t.second.first += lengths[e];
        t.second.second += L;
      }
    }
  }
  out << "total,,,,strut,,,," << millimetres(strut_length) << ',' << millimetres(strut_length) << ",,," << struts
      << "\n";
  for (const auto& [name, t] : per_material)
    out << "total,,,,cable,,," << csv_field(name) << ',' << millimetres(t.second.first) << ','
        << millimetres(t.second.second) << ",,," << t.first << "\n";
  return out.str();
}

void write_cut_list(const Design& d, const Eigen::VectorXd& lengths, const std::string& path) {
  const Structure& s = d.structure;
  const auto groups = assembly_groups(s);
  constexpr double kRow = 18, kWidth = 794, kLeft = 40;  // px; 794 px = A4 width at 96 dpi
  const double longest = std::max(lengths.maxCoeff(), 1e-9);
  const double bar_scale = 260.0 / longest;  // px per metre
  const int rows = s.num_elements() + 3 * static_cast<int>(groups.size()) + 8;
  Canvas c(static_cast<int>(kWidth), static_cast<int>(rows * kRow + 80));
  const Colour ink{0, 0, 0}, strut_colour{0.15, 0.2, 0.45}, cable_colour{0.75, 0.3, 0.05}, grey{0.4, 0.4, 0.4};
  double y = 40;
  c.text(kLeft, y, "Cut list: " + s.name + " (lengths in mm; struts: cut length, cables: rest length to tie)", 15, ink);
  y += kRow * 1.5;
  for (const AssemblyGroup& g : groups) {
    c.text(kLeft, y, g.kind + " " + g.id, 13, ink);
    y += kRow;
    for (int e : g.elements) {
      const bool strut = s.elements[e].kind == ElementKind::Strut;
      const double shown = strut ? lengths[e] : (*d.solution.rest_lengths)[e];
      c.set_attributes({{"data-element", element_name(s, e)}, {"data-index", std::to_string(e)}});
      c.text(kLeft + 10, y, element_name(s, e), 11, ink);
      c.text(kLeft + 230, y, strut ? "strut" : "cable " + d.cable_material[e], 11, grey);
      c.text(kLeft + 420, y, millimetres(shown), 11, ink, TextAnchor::End);
      c.rectangle(kLeft + 435, y - 8, shown * bar_scale, strut ? 6 : 2, strut ? strut_colour : cable_colour);
      c.clear_attributes();
      y += kRow;
    }
    y += kRow * 0.5;
  }
  int struts = 0;
  double strut_total = 0.0;
  std::map<std::string, std::pair<int, double>> cords;
  for (int e = 0; e < s.num_elements(); ++e)
    if (s.elements[e].kind == ElementKind::Strut) ++struts, strut_total += lengths[e];
    else ++cords[d.cable_material[e]].first, cords[d.cable_material[e]].second += (*d.solution.rest_lengths)[e];
  c.text(kLeft, y, "totals: " + std::to_string(struts) + " struts, " + millimetres(strut_total) + " mm of tube", 13, ink);
  y += kRow;
  for (const auto& [name, t] : cords) {
    c.text(kLeft, y, "        " + std::to_string(t.first) + " cables of " + name + ", " + millimetres(t.second) +
                         " mm of cord at rest (plus knots)", 13, ink);
    y += kRow;
  }
  c.write(path);
}

}  // namespace tensegrity::reports
