#pragma once
// Line-geometry exports of a scene at given positions with per-element forces:
// VTK legacy (ParaView: cell data "force" in N and "kind" 0 strut / 1 cable),
// PLY (an "edge" element with force and kind properties; Blender, MeshLab) and
// Wavefront OBJ (polylines in groups "struts" and "cables", the force of each
// line in a comment, since OBJ has no per-line data).
#include <Eigen/Core>
#include <string>

#include "model/structure.hpp"

namespace tensegrity::cli {

enum class ExportFormat { Vtk, Obj, Ply };

// Throws InputError("command line", "--format", ...) for an unknown name.
ExportFormat export_format_from_string(const std::string& name);

std::string export_lines(const Structure& scene, const Eigen::Matrix3Xd& positions, const Eigen::VectorXd& forces,
                         ExportFormat format);

}  // namespace tensegrity::cli
