#include "reports/renderer.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>

#include "reports/canvas.hpp"
#include "reports/exporters.hpp"
#include "model/errors.hpp"

namespace tensegrity::reports {

namespace {

constexpr int kLegendMinimumWidth = 640;  // px: narrower pictures (film strips) get no legend
constexpr double kLegendPanelWidth = 230;  // px

// Rows: screen right, screen up, towards the viewer.
Eigen::Matrix3d picture_view_basis(const std::string& view) {
  Eigen::Matrix3d B;
  if (view == "front") {
    B << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  } else if (view == "side") {
    B << 0, 1, 0, 0, 0, 1, 1, 0, 0;
  } else if (view == "top") {
    B << 1, 0, 0, 0, 1, 0, 0, 0, 1;
  } else if (view == "iso") {
    const Eigen::Vector3d toward_viewer = Eigen::Vector3d(0.6, -1.0, 0.7).normalized();
    const Eigen::Vector3d right = Eigen::Vector3d::UnitZ().cross(toward_viewer).normalized();
    const Eigen::Vector3d up = toward_viewer.cross(right);
    B.row(0) = right;
    B.row(1) = up;
    B.row(2) = toward_viewer;
  } else {
    throw InputError("command line", "--view", "must be front, side, top or iso (got '" + view + "')");
  }
  return B;
}

Colour blend(const Colour& a, const Colour& b, double t) {
  t = std::clamp(t, 0.0, 1.0);
  return {a.r + (b.r - a.r) * t, a.g + (b.g - a.g) * t, a.b + (b.b - a.b) * t};
}

const Colour kZeroForce{0.78, 0.78, 0.78}, kCompression{0.05, 0.2, 0.75}, kTension{0.75, 0.05, 0.05};
const Colour kStrutPlain{0.15, 0.2, 0.45}, kCablePlain{0.85, 0.45, 0.1}, kSlack{0.6, 0.6, 0.6};
const Colour kInk{0, 0, 0}, kGround{0.7, 0.7, 0.7}, kFaint{0.82, 0.82, 0.86};
// Sixteen distinguishable hues (the scorpion has 12 blocks); beyond that they repeat.
const Colour kBlockColours[] = {{0.12, 0.47, 0.71}, {1.0, 0.5, 0.05},   {0.17, 0.63, 0.17}, {0.84, 0.15, 0.16},
                                {0.58, 0.4, 0.74},  {0.55, 0.34, 0.29}, {0.89, 0.47, 0.76}, {0.74, 0.74, 0.13},
                                {0.09, 0.75, 0.81}, {0.0, 0.0, 0.5},    {0.5, 0.5, 0.0},    {0.0, 0.5, 0.5},
                                {0.5, 0.0, 0.0},    {0.4, 0.8, 0.4},    {1.0, 0.8, 0.2},    {0.6, 0.6, 1.0}};

// Diverging force scale: t in [-1, 1].
Colour force_scale_colour(double t) {
  return t < 0 ? blend(kZeroForce, kCompression, -t) : blend(kZeroForce, kTension, t);
}
// Sequential strain scale: t in [0, 1].
Colour strain_scale_colour(double t) { return blend({1.0, 0.85, 0.5}, {0.5, 0.0, 0.3}, t); }

std::string format_number(double v, const char* format = "%.3g") {
  char buf[48];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

// 1, 2 or 5 times a power of ten, at most `limit`.
double round_length(double limit) {
  const double p = std::pow(10.0, std::floor(std::log10(limit)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * p <= limit) return m * p;
  return p;
}

std::string length_text(double metres) {
  if (metres >= 1.0) return format_number(metres, "%g") + " m";
  if (metres >= 0.01) return format_number(metres * 100, "%g") + " cm";
  return format_number(metres * 1000, "%g") + " mm";
}

std::string block_of(const Structure& s, int e) {
  if (e >= static_cast<int>(s.element_extra.size())) return "";
  const auto& x = s.element_extra[e];
  if (x.contains("block")) return x["block"].is_string() ? x["block"].get<std::string>() : x["block"].dump();
  return "";
}

}  // namespace

void render_structure(const Structure& scene, const Eigen::Matrix3Xd& x, const RenderData& data,
                      const RenderOptions& options, const std::string& path) {
  const Eigen::Matrix3d B = picture_view_basis(options.view);
  if (!ends_with(path, ".png") && !ends_with(path, ".svg"))
    throw InputError("command line", "--out", "must end in .png or .svg");
  std::string colour_by = options.colour_by;
  if (colour_by != "force" && colour_by != "strain" && colour_by != "block" && colour_by != "kind")
    throw InputError("command line", "--colour-by", "must be force, strain, block or kind (got '" + colour_by + "')");
  if (colour_by == "force" && !data.forces) colour_by = "kind";
  if (colour_by == "strain" && !data.strains)
    throw InputError("command line", "--colour-by strain", "needs a design (it carries the strains)");
  const int n = static_cast<int>(x.cols()), m = scene.num_elements();
  const bool legend = options.legend && options.width >= kLegendMinimumWidth;
  const double draw_width = options.width - (legend ? kLegendPanelWidth : 0.0);
  const Eigen::Matrix3Xd p = B * x;

  // Fit the drawing (and the reference shape) into the picture area with a margin.
  Eigen::Vector2d lo = p.topRows<2>().rowwise().minCoeff(), hi = p.topRows<2>().rowwise().maxCoeff();
  Eigen::Matrix3Xd p_ref;
  if (data.reference) {
    p_ref = B * *data.reference;
    lo = lo.cwiseMin(p_ref.topRows<2>().rowwise().minCoeff());
    hi = hi.cwiseMax(p_ref.topRows<2>().rowwise().maxCoeff());
  }
  const double span = std::max({hi.x() - lo.x(), hi.y() - lo.y(), 1e-12});
  const double margin = 0.1;
  const double scale = std::min(draw_width * (1 - 2 * margin) / std::max(hi.x() - lo.x(), 1e-3 * span),
                                options.height * (1 - 2 * margin) / std::max(hi.y() - lo.y(), 1e-3 * span));
  const Eigen::Vector2d centre = 0.5 * (lo + hi);
  auto sx = [&](const Eigen::Vector3d& q) { return draw_width / 2.0 + scale * (q.x() - centre.x()); };
  auto sy = [&](const Eigen::Vector3d& q) { return options.height / 2.0 - scale * (q.y() - centre.y()); };

  Canvas c(options.width, options.height);
  const double strut_width = std::max(3.0, options.width / 180.0), cable_width = std::max(1.2, options.width / 800.0);
  const double font = std::max(10.0, options.height / 60.0);

  // Ground: the plane through the lowest fixed node, outlined under the structure.
  double ground_z = 1e300;
  for (int i = 0; i < n; ++i)
    if (scene.fixed[i]) ground_z = std::min(ground_z, x(2, i));
  const bool has_ground = ground_z < 1e299;
  if (has_ground && options.view != "top") {
    Eigen::Vector3d g0 = x.rowwise().minCoeff(), g1 = x.rowwise().maxCoeff();
    const double pad = 0.1 * (g1 - g0).head<2>().norm();
    std::vector<std::pair<double, double>> outline;
    for (const auto& [gx, gy] : {std::pair{g0.x() - pad, g0.y() - pad}, std::pair{g1.x() + pad, g0.y() - pad},
                                 std::pair{g1.x() + pad, g1.y() + pad}, std::pair{g0.x() - pad, g1.y() + pad}}) {
      const Eigen::Vector3d q = B * Eigen::Vector3d(gx, gy, ground_z);
      outline.emplace_back(sx(q), sy(q));
    }
    c.set_attributes({{"class", "ground"}});
    c.polyline(outline, kGround, 1.5, false, true);
    c.clear_attributes();
  }

  if (data.reference) {
    c.set_attributes({{"class", "reference"}});
    for (const auto& el : scene.elements)
      c.line(sx(p_ref.col(el.a)), sy(p_ref.col(el.a)), sx(p_ref.col(el.b)), sy(p_ref.col(el.b)), kFaint,
             el.kind == ElementKind::Strut ? strut_width * 0.6 : cable_width);
    c.clear_attributes();
  }

  double max_force = 0.0, max_strain = 0.0;
  if (data.forces) max_force = data.forces->cwiseAbs().maxCoeff();
  if (data.strains)
    for (int e = 0; e < m; ++e)
      if (scene.elements[e].kind == ElementKind::Cable) max_strain = std::max(max_strain, (*data.strains)[e]);
  std::map<std::string, Colour> block_colours;
  for (int e = 0; e < m; ++e) {
    const std::string b = block_of(scene, e);
    if (!b.empty() && !block_colours.count(b))
      block_colours[b] = kBlockColours[block_colours.size() % std::size(kBlockColours)];
  }

  // Painter's order, far first; a cable lying on a strut is drawn over it
  // (its depth is taken a strut's width nearer the viewer).
  const double cable_lift = 3.0 * strut_width / scale;
  auto depth = [&](int e) {
    const double d = 0.5 * (p(2, scene.elements[e].a) + p(2, scene.elements[e].b));
    return scene.elements[e].kind == ElementKind::Cable ? d + cable_lift : d;
  };
  std::vector<int> order(m);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return depth(a) < depth(b); });
  for (int e : order) {
    const auto& el = scene.elements[e];
    const bool strut = el.kind == ElementKind::Strut;
    const bool slack = !strut && data.forces && (*data.forces)[e] <= 0.0;
    Colour colour = strut ? kStrutPlain : kCablePlain;
    if (colour_by == "force") colour = force_scale_colour((*data.forces)[e] / std::max(max_force, 1e-300));
    if (colour_by == "strain") colour = strut ? kStrutPlain : strain_scale_colour((*data.strains)[e] / std::max(max_strain, 1e-300));
    if (colour_by == "block") {
      const std::string b = block_of(scene, e);
      colour = b.empty() ? Colour{0.45, 0.45, 0.45} : block_colours[b];
    }
    if (slack) colour = kSlack;
    std::map<std::string, std::string> attributes = {{"data-element", element_name(scene, e)},
                                                     {"data-index", std::to_string(e)},
                                                     {"class", strut ? "strut" : slack ? "cable slack" : "cable"}};
    if (data.forces) attributes["data-force-N"] = format_number((*data.forces)[e], "%.6g");
    c.set_attributes(attributes);
    const double x0 = sx(p.col(el.a)), y0 = sy(p.col(el.a)), x1 = sx(p.col(el.b)), y1 = sy(p.col(el.b));
    if (strut) c.line(x0, y0, x1, y1, {0.05, 0.05, 0.1}, strut_width + 2.0);  // a rim keeps crossing struts apart
    c.line(x0, y0, x1, y1, colour, strut ? strut_width : cable_width, slack);
    c.clear_attributes();
  }
  const double box = strut_width * 1.6;
  for (int i = 0; i < n; ++i)
    if (scene.fixed[i]) {
      c.set_attributes({{"class", "fixed-node"}, {"data-node", std::to_string(i)}});
      c.rectangle(sx(p.col(i)) - box / 2, sy(p.col(i)) - box / 2, box, box, kInk);
      c.clear_attributes();
    }
  if (options.labels) {
    const double small = font * 0.8;
    for (int i = 0; i < n; ++i)
      c.text(sx(p.col(i)) + 4, sy(p.col(i)) - 4, std::to_string(i), small, {0.1, 0.1, 0.1});
    for (int e = 0; e < m; ++e) {
      const Eigen::Vector3d mid = 0.5 * (p.col(scene.elements[e].a) + p.col(scene.elements[e].b));
      c.text(sx(mid), sy(mid) + small / 3, "e" + std::to_string(e), small * 0.9, {0.35, 0.1, 0.45},
             TextAnchor::Middle);
    }
  }
  if (!options.title.empty()) c.text(options.width * 0.02, options.height * 0.05, options.title, options.height / 30.0, kInk);
  if (!legend) {
    c.write(path);
    return;
  }

  // The legend panel: key, colour bar, scale bar, axes.
  const double lx = draw_width + 10, row = font * 1.7;
  double ly = options.height * 0.08;
  c.rectangle(draw_width, 0, kLegendPanelWidth, options.height, {0.97, 0.97, 0.97});
  c.text(lx, ly, "key", font * 1.1, kInk);
  ly += row;
  auto key_line = [&](const std::string& label, Colour colour, double width, bool dashed) {
    c.line(lx, ly - font / 3, lx + 40, ly - font / 3, colour, width, dashed);
    c.text(lx + 50, ly, label, font, kInk);
    ly += row;
  };
  key_line("strut", colour_by == "force" ? kCompression : kStrutPlain, strut_width, false);
  key_line("cable", colour_by == "force" ? kTension : kCablePlain, cable_width * 1.5, false);
  if (data.forces) key_line("slack cable", kSlack, cable_width * 1.5, true);
  if (has_ground) {
    c.rectangle(lx + 20 - box / 2, ly - font / 3 - box / 2, box, box, kInk);
    c.text(lx + 50, ly, "fixed node", font, kInk);
    ly += row;
    key_line("ground outline", kGround, 1.5, false);
  }
  if (data.reference) key_line("before (reference)", kFaint, strut_width * 0.6, false);
  ly += row * 0.5;

  if (colour_by == "force" || colour_by == "strain") {
    const bool force = colour_by == "force";
    c.text(lx, ly, force ? "axial force (N)" : "cable strain", font * 1.1, kInk);
    ly += row * 0.6;
    const double bar_h = options.height * 0.3, bar_w = 22;
    const int steps = 64;
    for (int k = 0; k < steps; ++k) {
      const double t = 1.0 - (k + 0.5) / steps;  // top = largest
      const Colour colour = force ? force_scale_colour(2 * t - 1) : strain_scale_colour(t);
      c.rectangle(lx, ly + bar_h * k / steps, bar_w, bar_h / steps + 0.5, colour);
    }
    c.rectangle_outline(lx, ly, bar_w, bar_h, kInk, 1);
    const double top = force ? max_force : max_strain, bottom = force ? -max_force : 0.0;
    for (int k = 0; k <= 4; ++k) {
      const double v = top + (bottom - top) * k / 4.0;
      const double y = ly + bar_h * k / 4.0;
      c.line(lx + bar_w, y, lx + bar_w + 5, y, kInk, 1);
      c.text(lx + bar_w + 8, y + font / 3, format_number(v, "%.3g"), font * 0.9, kInk);
    }
    if (force) {
      c.text(lx + bar_w + 70, ly + font / 3, "tension", font * 0.85, kTension);
      c.text(lx + bar_w + 70, ly + bar_h + font / 3, "compression", font * 0.85, kCompression);
    }
    ly += bar_h + row;
  } else if (colour_by == "block") {
    c.text(lx, ly, "blocks", font * 1.1, kInk);
    ly += row;
    for (const auto& [name, colour] : block_colours) key_line(name, colour, strut_width, false);
    key_line("links", {0.45, 0.45, 0.45}, strut_width, false);
  }

  // Scale bar: a round length of at most a third of the panel, at picture scale.
  const double bar_m = round_length((kLegendPanelWidth - 40) / scale);
  c.text(lx, ly, "scale", font * 1.1, kInk);
  ly += row * 0.8;
  c.line(lx, ly, lx + bar_m * scale, ly, kInk, 3);
  c.line(lx, ly - 5, lx, ly + 5, kInk, 1.5);
  c.line(lx + bar_m * scale, ly - 5, lx + bar_m * scale, ly + 5, kInk, 1.5);
  c.text(lx, ly + row, length_text(bar_m), font, kInk);
  ly += row * 2;

  // Axis triad: the world axes as seen in this view.
  const double ax = lx + 50, ay = std::min(ly + 60, options.height - 60.0), len = 40;
  const char* names[] = {"x", "y", "z"};
  const Colour axis_colours[] = {{0.8, 0.1, 0.1}, {0.1, 0.6, 0.1}, {0.1, 0.2, 0.8}};
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d dir = B.col(k);
    if (dir.head<2>().norm() < 1e-6) {
      c.circle(ax, ay, 4, axis_colours[k]);  // pointing at the viewer or away
      c.text(ax + 6, ay - 6, names[k], font, axis_colours[k]);
      continue;
    }
    const double ex = ax + len * dir.x(), ey = ay - len * dir.y();
    c.line(ax, ay, ex, ey, axis_colours[k], 2);
    c.text(ex + 4 * dir.x(), ey - 4 * dir.y() + font / 3, names[k], font, axis_colours[k], TextAnchor::Middle);
  }
  c.write(path);
}

}  // namespace tensegrity::reports
