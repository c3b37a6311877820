#pragma once
// Pictures of a scene with Cairo: struts thick, cables thin, coloured by force
// when forces are given (cables: tension, light to dark red; struts:
// compression, light to dark blue; scaled by the largest |force| of the kind),
// fixed nodes as black squares on a ground line. Orthographic views with z up:
// front = the x-z plane seen from -y, side = the y-z plane seen from +x,
// top = the x-y plane seen from +z, iso = an axonometric view from (1, -1, 0.8)
// towards the origin direction.
#include <Eigen/Core>
#include <optional>
#include <string>

#include "model/structure.hpp"

namespace tensegrity::cli {

struct RenderOptions {
  std::string view = "iso";  // front | side | top | iso
  int width = 1200;          // px
  int height = 900;          // px
  std::string title;         // drawn in the top-left corner when not empty
};

// Writes PNG or SVG by the extension of `path`. Throws InputError for an
// unknown view or extension, std::runtime_error when Cairo fails to write.
void render_scene(const Structure& scene, const Eigen::Matrix3Xd& positions,
                  const std::optional<Eigen::VectorXd>& forces, const RenderOptions& options,
                  const std::string& path);

}  // namespace tensegrity::cli
