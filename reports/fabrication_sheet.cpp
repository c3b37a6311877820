#include "reports/fabrication_sheet.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <sstream>
#include <vector>

#include "model/text_file.hpp"
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

namespace {

// The cut list's layout in px (96 dpi): 794 x 1123 px is an A4 page.
constexpr double kCutListRow = 18, kCutListWidth = 794, kCutListLeft = 40, kCutListTop = 40;
constexpr double kA4Height = 1123, kBottomMargin = 50;
constexpr double kBarLength = 260;  // px of the longest element's bar

// Rows placed one after another on one tall canvas, or on pages of a fixed
// height (each continued page headed by the title).
class CutListPages {
 public:
  // paged: a new page when a row would pass the bottom margin; otherwise one
  // canvas of page_height, which must hold every row.
  CutListPages(std::string title, double page_height, bool paged)
      : title_(std::move(title)), page_height_(page_height), paged_(paged) {
    new_page();
  }
  // The y of a row of height h (px) times `rows_kept_together` rows, on this page or the next.
  double place(double h, int rows_kept_together = 1) {
    if (paged_ && y_ + h * rows_kept_together > page_height_ - kBottomMargin) new_page();
    const double at = y_;
    y_ += h;
    return at;
  }
  Canvas& canvas() { return pages_.back(); }
  std::vector<Canvas> take() { return std::move(pages_); }

 private:
  void new_page() {
    const bool continued = !pages_.empty();
    pages_.emplace_back(static_cast<int>(kCutListWidth), static_cast<int>(page_height_));
    y_ = kCutListTop;
    pages_.back().text(kCutListLeft, y_, title_ + (continued ? " (continued)" : ""), 15, Colour{0, 0, 0});
    y_ += kCutListRow * 1.5;
  }
  std::string title_;
  double page_height_, y_ = 0;
  bool paged_;
  std::vector<Canvas> pages_;
};

std::vector<Canvas> lay_out_cut_list(const Design& d, const Eigen::VectorXd& lengths, double page_height,
                                     bool paged) {
  const Structure& s = d.structure;
  const auto groups = assembly_groups(s);
  const double longest = std::max(lengths.maxCoeff(), 1e-9);
  const double bar_scale = kBarLength / longest;  // px per metre
  const Colour ink{0, 0, 0}, strut_colour{0.15, 0.2, 0.45}, cable_colour{0.75, 0.3, 0.05}, grey{0.4, 0.4, 0.4};
  CutListPages pages("Cut list: " + s.name + " (lengths in mm; struts: cut length, cables: rest length to tie)",
                     page_height, paged);
  const double left = kCutListLeft;
  for (const AssemblyGroup& g : groups) {
    // A group's heading stays with its first rows.
    constexpr int kHeadingWithRows = 3;
    pages.canvas().text(left, pages.place(kCutListRow, kHeadingWithRows), g.kind + " " + g.id, 13, ink);
    for (int e : g.elements) {
      const bool strut = s.elements[e].kind == ElementKind::Strut;
      const double shown = strut ? lengths[e] : (*d.solution.rest_lengths)[e];
      const double y = pages.place(kCutListRow);
      Canvas& c = pages.canvas();
      c.set_attributes({{"data-element", element_name(s, e)}, {"data-index", std::to_string(e)}});
      c.text(left + 10, y, element_name(s, e), 11, ink);
      c.text(left + 230, y, strut ? "strut" : "cable " + d.cable_material[e], 11, grey);
      c.text(left + 420, y, millimetres(shown), 11, ink, TextAnchor::End);
      c.rectangle(left + 435, y - 8, shown * bar_scale, strut ? 6 : 2, strut ? strut_colour : cable_colour);
      c.clear_attributes();
    }
    pages.place(kCutListRow * 0.5);
  }
  int struts = 0;
  double strut_total = 0.0;
  std::map<std::string, std::pair<int, double>> cords;
  for (int e = 0; e < s.num_elements(); ++e)
    if (s.elements[e].kind == ElementKind::Strut) ++struts, strut_total += lengths[e];
    else ++cords[d.cable_material[e]].first, cords[d.cable_material[e]].second += (*d.solution.rest_lengths)[e];
  const int total_rows = 1 + static_cast<int>(cords.size());
  pages.canvas().text(left, pages.place(kCutListRow, total_rows),
                      "totals: " + std::to_string(struts) + " struts, " + millimetres(strut_total) + " mm of tube", 13,
                      ink);
  for (const auto& [name, t] : cords)
    pages.canvas().text(left, pages.place(kCutListRow),
                        "        " + std::to_string(t.first) + " cables of " + name + ", " + millimetres(t.second) +
                            " mm of cord at rest (plus knots)",
                        13, ink);
  return pages.take();
}

}  // namespace

void write_cut_list(const Design& d, const Eigen::VectorXd& lengths, const std::string& path) {
  if (path.size() >= 4 && path.compare(path.size() - 4, 4, ".pdf") == 0) {
    write_text_file_atomically(path, Canvas::pdf_bytes(lay_out_cut_list(d, lengths, kA4Height, true)));
    return;
  }
  // One canvas as tall as the list (SVG for the screen, PNG).
  const Structure& s = d.structure;
  const int rows = s.num_elements() + 3 * static_cast<int>(assembly_groups(s).size()) + 8;
  std::vector<Canvas> one = lay_out_cut_list(d, lengths, rows * kCutListRow + 80, false);
  one.front().write(path);
}

}  // namespace tensegrity::reports
