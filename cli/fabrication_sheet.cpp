#include "cli/fabrication_sheet.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <sstream>
#include <vector>

namespace tensegrity::cli {

namespace {

// Block and link groups in assembly order: blocks first, then links, each in
// the order they first appear; elements without an id last.
struct Group {
  std::string kind, id;
  std::vector<int> elements;
};

std::string id_text(const nlohmann::json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); }

std::vector<Group> assembly_groups(const Structure& s) {
  std::vector<Group> blocks, links;
  Group rest{"none", "", {}};
  auto find_or_add = [](std::vector<Group>& groups, const std::string& kind, const std::string& id) -> Group& {
    for (auto& g : groups)
      if (g.id == id) return g;
    groups.push_back(Group{kind, id, {}});
    return groups.back();
  };
  for (int e = 0; e < s.num_elements(); ++e) {
    const nlohmann::json extra =
        e < static_cast<int>(s.element_extra.size()) ? s.element_extra[e] : nlohmann::json::object();
    if (extra.contains("block")) find_or_add(blocks, "block", id_text(extra.at("block"))).elements.push_back(e);
    else if (extra.contains("link")) find_or_add(links, "link", id_text(extra.at("link"))).elements.push_back(e);
    else rest.elements.push_back(e);
  }
  std::vector<Group> out = blocks;
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

std::string number17(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

std::string fabrication_sheet_csv(const Design& d, const Eigen::VectorXd& lengths) {
  const Structure& s = d.structure;
  std::ostringstream out;
  out << "group_kind,group,element,kind,node_a,node_b,material,length_m,rest_length_m,force_N,strain,count\n";
  int struts = 0;
  double strut_length = 0.0;
  std::map<std::string, std::pair<int, std::pair<double, double>>> per_material;  // count, (l, L)
  for (const Group& g : assembly_groups(s)) {
    for (int e : g.elements) {
      const bool strut = s.elements[e].kind == ElementKind::Strut;
      const double L = (*d.solution.rest_lengths)[e];
      out << g.kind << ',' << csv_field(g.id) << ',' << e << ',' << (strut ? "strut" : "cable") << ','
          << s.elements[e].a << ',' << s.elements[e].b << ',' << csv_field(d.cable_material[e]) << ','
          << number17(lengths[e]) << ',' << number17(L) << ',' << number17(d.solution.forces[e]) << ','
          << number17(d.strains[e]) << ",1\n";
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
  out << "total,,,strut,,,," << number17(strut_length) << ',' << number17(strut_length) << ",,," << struts << "\n";
  for (const auto& [name, t] : per_material)
    out << "total,,,cable,,," << csv_field(name) << ',' << number17(t.second.first) << ','
        << number17(t.second.second) << ",,," << t.first << "\n";
  return out.str();
}

}  // namespace tensegrity::cli
