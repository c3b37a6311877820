#include "cli/renderer.hpp"

#include <cairo-svg.h>
#include <cairo.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <numeric>
#include <stdexcept>

#include "model/errors.hpp"

namespace tensegrity::cli {

namespace {

// Rows: screen right, screen up, towards the viewer.
Eigen::Matrix3d view_basis(const std::string& view) {
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

struct Rgb {
  double r, g, b;
};

Rgb mix(const Rgb& a, const Rgb& b, double t) {
  t = std::clamp(t, 0.0, 1.0);
  return {a.r + (b.r - a.r) * t, a.g + (b.g - a.g) * t, a.b + (b.b - a.b) * t};
}

}  // namespace

void render_scene(const Structure& scene, const Eigen::Matrix3Xd& x, const std::optional<Eigen::VectorXd>& forces,
                  const RenderOptions& options, const std::string& path) {
  const Eigen::Matrix3d B = view_basis(options.view);
  const bool svg = path.size() > 4 && path.substr(path.size() - 4) == ".svg";
  const bool png = path.size() > 4 && path.substr(path.size() - 4) == ".png";
  if (!svg && !png) throw InputError("command line", "--out", "must end in .png or .svg");
  const int n = static_cast<int>(x.cols()), m = scene.num_elements();
  const Eigen::Matrix3Xd p = B * x;

  // Fit the drawing (with the ground line) into the image with a margin.
  Eigen::Vector2d lo = p.topRows<2>().rowwise().minCoeff(), hi = p.topRows<2>().rowwise().maxCoeff();
  const double span = std::max({hi.x() - lo.x(), hi.y() - lo.y(), 1e-12});
  const double margin = 0.08;
  const double scale = std::min(options.width * (1 - 2 * margin) / std::max(hi.x() - lo.x(), 1e-3 * span),
                                options.height * (1 - 2 * margin) / std::max(hi.y() - lo.y(), 1e-3 * span));
  const Eigen::Vector2d centre = 0.5 * (lo + hi);
  auto sx = [&](const Eigen::Vector3d& q) { return options.width / 2.0 + scale * (q.x() - centre.x()); };
  auto sy = [&](const Eigen::Vector3d& q) { return options.height / 2.0 - scale * (q.y() - centre.y()); };

  cairo_surface_t* surface = svg ? cairo_svg_surface_create(path.c_str(), options.width, options.height)
                                 : cairo_image_surface_create(CAIRO_FORMAT_ARGB32, options.width, options.height);
  cairo_t* cr = cairo_create(surface);
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);

  // Ground: the plane through the lowest fixed node, drawn as a line in side views.
  double ground_z = 1e300;
  for (int i = 0; i < n; ++i)
    if (scene.fixed[i]) ground_z = std::min(ground_z, x(2, i));
  if (ground_z < 1e299 && options.view != "top") {
    cairo_set_source_rgb(cr, 0.75, 0.75, 0.75);
    cairo_set_line_width(cr, 2.0);
    Eigen::Vector3d g0 = x.rowwise().minCoeff(), g1 = x.rowwise().maxCoeff();
    g0.z() = g1.z() = ground_z;
    const Eigen::Vector3d a = B * Eigen::Vector3d(g0.x(), g0.y(), ground_z);
    const Eigen::Vector3d b = B * Eigen::Vector3d(g1.x(), g1.y(), ground_z);
    const Eigen::Vector3d c = B * Eigen::Vector3d(g0.x(), g1.y(), ground_z);
    const Eigen::Vector3d d = B * Eigen::Vector3d(g1.x(), g0.y(), ground_z);
    cairo_move_to(cr, sx(a), sy(a));
    cairo_line_to(cr, sx(d), sy(d));
    cairo_line_to(cr, sx(b), sy(b));
    cairo_line_to(cr, sx(c), sy(c));
    cairo_close_path(cr);
    cairo_stroke(cr);
  }

  double max_tension = 0.0, max_compression = 0.0;
  if (forces)
    for (int e = 0; e < m; ++e)
      (scene.elements[e].kind == ElementKind::Cable ? max_tension : max_compression) =
          std::max(scene.elements[e].kind == ElementKind::Cable ? max_tension : max_compression,
                   std::abs((*forces)[e]));

  // Painter's order: far elements first; cables before struts at equal depth.
  std::vector<int> order(m);
  std::iota(order.begin(), order.end(), 0);
  auto depth = [&](int e) { return 0.5 * (p(2, scene.elements[e].a) + p(2, scene.elements[e].b)); };
  std::sort(order.begin(), order.end(), [&](int a, int b) { return depth(a) < depth(b); });
  const double strut_width = std::max(3.0, options.width / 180.0), cable_width = std::max(1.0, options.width / 900.0);
  for (int e : order) {
    const auto& el = scene.elements[e];
    const bool strut = el.kind == ElementKind::Strut;
    Rgb c;
    if (!forces) {
      c = strut ? Rgb{0.15, 0.2, 0.45} : Rgb{0.85, 0.45, 0.1};
    } else if (strut) {
      c = mix({0.55, 0.7, 0.95}, {0.02, 0.1, 0.5}, std::abs((*forces)[e]) / std::max(max_compression, 1e-300));
    } else {
      c = mix({1.0, 0.7, 0.55}, {0.6, 0.0, 0.0}, std::abs((*forces)[e]) / std::max(max_tension, 1e-300));
    }
    if (strut) {  // a dark rim makes overlapping struts readable
      cairo_set_source_rgb(cr, 0.05, 0.05, 0.1);
      cairo_set_line_width(cr, strut_width + 2.0);
      cairo_move_to(cr, sx(p.col(el.a)), sy(p.col(el.a)));
      cairo_line_to(cr, sx(p.col(el.b)), sy(p.col(el.b)));
      cairo_stroke(cr);
    }
    cairo_set_source_rgb(cr, c.r, c.g, c.b);
    cairo_set_line_width(cr, strut ? strut_width : cable_width);
    cairo_move_to(cr, sx(p.col(el.a)), sy(p.col(el.a)));
    cairo_line_to(cr, sx(p.col(el.b)), sy(p.col(el.b)));
    cairo_stroke(cr);
  }
  cairo_set_source_rgb(cr, 0, 0, 0);
  const double box = strut_width * 1.6;
  for (int i = 0; i < n; ++i)
    if (scene.fixed[i]) {
      cairo_rectangle(cr, sx(p.col(i)) - box / 2, sy(p.col(i)) - box / 2, box, box);
      cairo_fill(cr);
    }
  if (!options.title.empty()) {
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr, options.height / 30.0);
    cairo_move_to(cr, options.width * 0.02, options.height * 0.05);
    cairo_show_text(cr, options.title.c_str());
  }
  cairo_destroy(cr);
  cairo_surface_flush(surface);
  cairo_status_t status = CAIRO_STATUS_SUCCESS;
  if (png) status = cairo_surface_write_to_png(surface, path.c_str());
  cairo_surface_finish(surface);
  if (status == CAIRO_STATUS_SUCCESS) status = cairo_surface_status(surface);
  cairo_surface_destroy(surface);
  if (status != CAIRO_STATUS_SUCCESS)
    throw std::runtime_error("cannot write " + path + ": " + cairo_status_to_string(status));
}

}  // namespace tensegrity::cli
