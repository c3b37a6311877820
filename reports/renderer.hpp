#pragma once
// Pictures of a structure for papers, drawn on a Canvas (PNG, or SVG with
// text as text and each element's name and index as attributes).
//
// Struts thick, cables thin; colour by force (a diverging scale: blue
// compression, grey zero, red tension, symmetric about 0 at the largest |force|,
// with a colour bar in N), by cable strain (with a colour bar), by block
// (one colour per block id, links grey) or by kind alone. A slack cable
// (force <= 0 where forces are given) is dashed grey. Fixed nodes are black
// squares on the ground (the plane through the lowest fixed node). An optional
// reference shape (the scene before form finding) is drawn faintly behind.
// Pictures at least 640 px wide carry a key (strut, cable, slack cable, fixed
// node, ground), the colour bar, a scale bar in m and an axis triad.
// Orthographic views with z up: front = the x-z plane seen from -y, side = the
// y-z plane seen from +x, top = the x-y plane seen from +z, iso = an
// axonometric view from (0.6, -1, 0.7).
#include <Eigen/Core>
#include <optional>
#include <string>

#include "model/structure.hpp"

namespace tensegrity::reports {

struct RenderOptions {
  std::string view = "iso";        // front | side | top | iso
  int width = 1200;                // px
  int height = 900;                // px
  std::string title;               // drawn in the top-left corner when not empty
  std::string colour_by = "force"; // force | strain | block | kind (force without forces: kind)
  bool labels = false;             // node and element ids
  bool legend = true;              // key, colour bar, scale bar, axes (only from 640 px wide)
};

// What to draw besides the structure's own positions.
struct RenderData {
  std::optional<Eigen::VectorXd> forces;       // N, per element
  std::optional<Eigen::VectorXd> strains;      // per element (cables), for colour_by strain
  std::optional<Eigen::Matrix3Xd> reference;   // drawn faintly behind
};

// Writes PNG or SVG by the extension of `path`. Throws InputError for an
// unknown view, colouring or extension, std::runtime_error when writing fails.
void render_structure(const Structure& scene, const Eigen::Matrix3Xd& positions, const RenderData& data,
                      const RenderOptions& options, const std::string& path);

// render_structure with element forces only (no strains, no reference shape).
inline void render_scene(const Structure& scene, const Eigen::Matrix3Xd& positions,
                         const std::optional<Eigen::VectorXd>& forces, const RenderOptions& options,
                         const std::string& path) {
  RenderData data;
  data.forces = forces;
  render_structure(scene, positions, data, options, path);
}

}  // namespace tensegrity::reports
