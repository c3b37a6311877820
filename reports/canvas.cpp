#include "reports/canvas.hpp"

#include <cairo-pdf.h>
#include <cairo.h>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "model/scene_io.hpp"

namespace tensegrity::reports {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string svg_colour(const Colour& c) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "rgb(%d,%d,%d)", static_cast<int>(std::lround(255 * c.r)),
                static_cast<int>(std::lround(255 * c.g)), static_cast<int>(std::lround(255 * c.b)));
  return buf;
}

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

}  // namespace

bool ends_with(const std::string& path, const std::string& suffix) {
  return path.size() >= suffix.size() && path.compare(path.size() - suffix.size(), suffix.size(), suffix) == 0;
}

void Canvas::line(double x0, double y0, double x1, double y1, Colour c, double width, bool dashed) {
  polyline({{x0, y0}, {x1, y1}}, c, width, dashed, false);
}

void Canvas::polyline(const std::vector<std::pair<double, double>>& points, Colour c, double width, bool dashed,
                      bool closed) {
  Shape s;
  s.kind = Kind::Polyline;
  s.points = points;
  s.colour = c;
  s.width = width;
  s.dashed = dashed;
  s.closed = closed;
  add(std::move(s));
}

void Canvas::rectangle(double x, double y, double w, double h, Colour fill) {
  Shape s;
  s.kind = Kind::Rectangle;
  s.points = {{x, y}};
  s.a = w;
  s.b = h;
  s.colour = fill;
  add(std::move(s));
}

void Canvas::rectangle_outline(double x, double y, double w, double h, Colour stroke, double width) {
  Shape s;
  s.kind = Kind::RectangleOutline;
  s.points = {{x, y}};
  s.a = w;
  s.b = h;
  s.colour = stroke;
  s.width = width;
  add(std::move(s));
}

void Canvas::circle(double x, double y, double radius, Colour fill) {
  Shape s;
  s.kind = Kind::Circle;
  s.points = {{x, y}};
  s.a = radius;
  s.colour = fill;
  add(std::move(s));
}

void Canvas::text(double x, double y, const std::string& t, double size, Colour c, TextAnchor anchor,
                  double angle_deg) {
  Shape s;
  s.kind = Kind::Text;
  s.points = {{x, y}};
  s.a = size;
  s.b = angle_deg;
  s.colour = c;
  s.text = t;
  s.anchor = anchor;
  add(std::move(s));
}

std::string Canvas::svg_text() const {
  std::ostringstream o;
  o << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width_ << "\" height=\"" << height_
    << "\" viewBox=\"0 0 " << width_ << ' ' << height_ << "\" font-family=\"sans-serif\">\n"
    << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  for (const Shape& s : shapes_) {
    std::string attrs;
    for (const auto& [k, v] : s.attributes) attrs += ' ' + k + "=\"" + xml_escape(v) + '"';
    const std::string opacity = s.colour.a < 1 ? " opacity=\"" + num(s.colour.a) + "\"" : "";
    switch (s.kind) {
      case Kind::Line:
      case Kind::Polyline: {
        o << '<' << (s.closed ? "polygon" : "polyline") << " points=\"";
        for (std::size_t i = 0; i < s.points.size(); ++i)
          o << (i ? " " : "") << num(s.points[i].first) << ',' << num(s.points[i].second);
        o << "\" fill=\"none\" stroke=\"" << svg_colour(s.colour) << "\" stroke-width=\"" << num(s.width)
          << "\" stroke-linecap=\"round\" stroke-linejoin=\"round\"" << opacity;
        if (s.dashed) o << " stroke-dasharray=\"" << num(3 * s.width) << ',' << num(3 * s.width) << '"';
        o << attrs << "/>\n";
        break;
      }
      case Kind::Rectangle:
        o << "<rect x=\"" << num(s.points[0].first) << "\" y=\"" << num(s.points[0].second) << "\" width=\""
          << num(s.a) << "\" height=\"" << num(s.b) << "\" fill=\"" << svg_colour(s.colour) << '"' << opacity
          << attrs << "/>\n";
        break;
      case Kind::RectangleOutline:
        o << "<rect x=\"" << num(s.points[0].first) << "\" y=\"" << num(s.points[0].second) << "\" width=\""
          << num(s.a) << "\" height=\"" << num(s.b) << "\" fill=\"none\" stroke=\"" << svg_colour(s.colour)
          << "\" stroke-width=\"" << num(s.width) << '"' << opacity << attrs << "/>\n";
        break;
      case Kind::Circle:
        o << "<circle cx=\"" << num(s.points[0].first) << "\" cy=\"" << num(s.points[0].second) << "\" r=\""
          << num(s.a) << "\" fill=\"" << svg_colour(s.colour) << '"' << opacity << attrs << "/>\n";
        break;
      case Kind::Text: {
        const char* anchor = s.anchor == TextAnchor::Start ? "start" : s.anchor == TextAnchor::Middle ? "middle" : "end";
        o << "<text x=\"" << num(s.points[0].first) << "\" y=\"" << num(s.points[0].second) << "\" font-size=\""
          << num(s.a) << "\" text-anchor=\"" << anchor << "\" fill=\"" << svg_colour(s.colour) << '"' << opacity;
        if (s.b != 0)
          o << " transform=\"rotate(" << num(-s.b) << ' ' << num(s.points[0].first) << ' ' << num(s.points[0].second)
            << ")\"";
        o << attrs << '>' << xml_escape(s.text) << "</text>\n";
        break;
      }
    }
  }
  o << "</svg>\n";
  return o.str();
}

namespace {

cairo_status_t append_bytes(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

}  // namespace

std::string Canvas::png_bytes() const {
  cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, width_, height_);
  cairo_t* cr = cairo_create(surface);
  draw(cr);
  cairo_destroy(cr);
  cairo_surface_flush(surface);
  std::string bytes;
  const cairo_status_t status = cairo_surface_write_to_png_stream(surface, append_bytes, &bytes);
  cairo_surface_destroy(surface);
  if (status != CAIRO_STATUS_SUCCESS)
    throw std::runtime_error(std::string("cannot encode the PNG: ") + cairo_status_to_string(status));
  return bytes;
}

std::string Canvas::pdf_bytes(const std::vector<Canvas>& pages) {
  std::string bytes;
  if (pages.empty()) return bytes;
  cairo_surface_t* surface = cairo_pdf_surface_create_for_stream(append_bytes, &bytes, kPointsPerPixel * pages[0].width_,
                                                                 kPointsPerPixel * pages[0].height_);
  cairo_t* cr = cairo_create(surface);
  for (const Canvas& page : pages) {
    cairo_pdf_surface_set_size(surface, kPointsPerPixel * page.width_, kPointsPerPixel * page.height_);
    cairo_save(cr);
    cairo_scale(cr, kPointsPerPixel, kPointsPerPixel);
    page.draw(cr);
    cairo_restore(cr);
    cairo_show_page(cr);
  }
  cairo_destroy(cr);
  cairo_surface_finish(surface);
  const cairo_status_t status = cairo_surface_status(surface);
  cairo_surface_destroy(surface);
  if (status != CAIRO_STATUS_SUCCESS)
    throw std::runtime_error(std::string("cannot encode the PDF: ") + cairo_status_to_string(status));
  return bytes;
}

void Canvas::draw(cairo_t* cr) const {
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_paint(cr);
  cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  for (const Shape& s : shapes_) {
    cairo_set_source_rgba(cr, s.colour.r, s.colour.g, s.colour.b, s.colour.a);
    switch (s.kind) {
      case Kind::Line:
      case Kind::Polyline: {
        if (s.points.empty()) break;
        cairo_set_line_width(cr, s.width);
        const double dash = 3 * s.width;
        cairo_set_dash(cr, &dash, s.dashed ? 1 : 0, 0);
        cairo_move_to(cr, s.points[0].first, s.points[0].second);
        for (std::size_t i = 1; i < s.points.size(); ++i) cairo_line_to(cr, s.points[i].first, s.points[i].second);
        if (s.closed) cairo_close_path(cr);
        cairo_stroke(cr);
        cairo_set_dash(cr, nullptr, 0, 0);
        break;
      }
      case Kind::Rectangle:
        cairo_rectangle(cr, s.points[0].first, s.points[0].second, s.a, s.b);
        cairo_fill(cr);
        break;
      case Kind::RectangleOutline:
        cairo_set_line_width(cr, s.width);
        cairo_rectangle(cr, s.points[0].first, s.points[0].second, s.a, s.b);
        cairo_stroke(cr);
        break;
      case Kind::Circle:
        cairo_arc(cr, s.points[0].first, s.points[0].second, s.a, 0, 2 * kPi);
        cairo_fill(cr);
        break;
      case Kind::Text: {
        cairo_set_font_size(cr, s.a);
        cairo_text_extents_t ext;
        cairo_text_extents(cr, s.text.c_str(), &ext);
        const double shift = s.anchor == TextAnchor::Start ? 0 : s.anchor == TextAnchor::Middle ? ext.x_advance / 2
                                                                                                  : ext.x_advance;
        cairo_save(cr);
        cairo_translate(cr, s.points[0].first, s.points[0].second);
        cairo_rotate(cr, -s.b * kPi / 180.0);
        cairo_move_to(cr, -shift, 0);
        cairo_show_text(cr, s.text.c_str());
        cairo_restore(cr);
        break;
      }
    }
  }
}

void Canvas::write(const std::string& path) const {
  if (ends_with(path, ".svg")) {
    write_text_file_atomically(path, svg_text());
    return;
  }
  if (!ends_with(path, ".png")) throw std::runtime_error("cannot write " + path + ": not .png or .svg");
  write_text_file_atomically(path, png_bytes());
}

}  // namespace tensegrity::reports
