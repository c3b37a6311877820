#pragma once
// A small 2-D drawing list written either as PNG (rasterised by Cairo) or as
// SVG written directly, so that text stays text (Cairo's SVG surface turns it
// into glyph outlines) and shapes can carry attributes such as element ids.
// Coordinates are pixels, origin top left, y down. Several canvases make the
// pages of one PDF.
#include <map>
#include <string>
#include <vector>

typedef struct _cairo cairo_t;  // Cairo stays out of the includes of this header

namespace tensegrity::reports {

struct Colour {
  double r = 0, g = 0, b = 0, a = 1;  // 0..1
};

enum class TextAnchor { Start, Middle, End };

class Canvas {
 public:
  Canvas(int width, int height) : width_(width), height_(height) {}
  int width() const { return width_; }
  int height() const { return height_; }

  // SVG attributes of the next shapes (for example data-element="a.strut-0");
  // cleared by clear_attributes. Ignored in PNG.
  void set_attributes(std::map<std::string, std::string> attributes) { attributes_ = std::move(attributes); }
  void clear_attributes() { attributes_.clear(); }

  void line(double x0, double y0, double x1, double y1, Colour c, double width, bool dashed = false);
  void polyline(const std::vector<std::pair<double, double>>& points, Colour c, double width, bool dashed = false,
                bool closed = false);
  void rectangle(double x, double y, double w, double h, Colour fill);
  void rectangle_outline(double x, double y, double w, double h, Colour stroke, double width);
  void circle(double x, double y, double radius, Colour fill);
  // `size` in px; `angle_deg` rotates counter-clockwise about (x, y).
  void text(double x, double y, const std::string& s, double size, Colour c, TextAnchor anchor = TextAnchor::Start,
            double angle_deg = 0.0);

  // Writes PNG or SVG by the extension of `path` (".png" / ".svg"), through a
  // temporary file and a rename. Throws std::runtime_error when writing fails.
  void write(const std::string& path) const;
  std::string svg_text() const;
  // A multi-page PDF, one page per canvas, 1 px = 0.75 pt (96 dpi): a
  // 794 x 1123 px canvas is an A4 page.
  static std::string pdf_bytes(const std::vector<Canvas>& pages);
  static constexpr double kPointsPerPixel = 0.75;

  // Approximate width of a text in px (for layout; sans-serif average).
  static double text_width(const std::string& s, double size) { return 0.55 * size * static_cast<double>(s.size()); }

 private:
  enum class Kind { Line, Polyline, Rectangle, RectangleOutline, Circle, Text };
  struct Shape {
    Kind kind = Kind::Line;
    std::vector<std::pair<double, double>> points;
    double a = 0, b = 0;  // rectangle size, circle radius (a), text size (a) and angle (b)
    Colour colour;
    double width = 1;
    bool dashed = false, closed = false;
    std::string text;
    TextAnchor anchor = TextAnchor::Start;
    std::map<std::string, std::string> attributes;
  };
  void add(Shape s) {
    s.attributes = attributes_;
    shapes_.push_back(std::move(s));
  }
  std::string png_bytes() const;  // the picture encoded as PNG
  void draw(cairo_t* cr) const;   // onto a Cairo context, in px

  int width_, height_;
  std::vector<Shape> shapes_;
  std::map<std::string, std::string> attributes_;
};

// True when `path` ends in `suffix` (case-sensitive).
bool ends_with(const std::string& path, const std::string& suffix);

}  // namespace tensegrity::reports
