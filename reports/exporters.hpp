#pragma once
// Exports of a scene at given positions with per-element forces, and the
// choice of format from a file name:
//   .vtk       VTK legacy polydata (ParaView): cell data "force" (N) and "kind"
//              (0 strut, 1 cable), point data "fixed"; `simulate` writes the same.
//   .ply       an "edge" element with force and kind properties (MeshLab).
//   .obj       Wavefront OBJ: two vertices per element, coloured by its force
//              ("v x y z r g b": blue compression, grey zero, red tension,
//              scaled by the largest |force|), lines grouped "struts" and
//              "cables"; Blender imports the colours as a vertex colour
//              attribute. The forces themselves go to a companion CSV.
//   .yaml/.yml NTRT YAML (cli/ntrt_yaml.hpp).
//   .mjcf.xml, .xml  MuJoCo MJCF, designs only (cli/mjcf.hpp).
#include <Eigen/Core>
#include <string>

#include "model/structure.hpp"

namespace tensegrity::reports {

enum class ExportFormat { Vtk, Obj, Ply, NtrtYaml, Mjcf };

// Throws InputError("command line", "--format", ...) for an unknown name.
ExportFormat export_format_from_string(const std::string& name);
// The format named by `format` when not empty, else by the extension of
// `path`; InputError when neither says.
ExportFormat export_format_for(const std::string& path, const std::string& format);

// Vtk, Obj or Ply text. `title` goes in the VTK header line.
std::string export_lines(const Structure& scene, const Eigen::Matrix3Xd& positions, const Eigen::VectorXd& forces,
                         ExportFormat format, const std::string& title = "");
// The OBJ's companion: "element,name,kind,node_a,node_b,force_N", one row per element.
std::string element_forces_csv(const Structure& scene, const Eigen::VectorXd& forces);
// "a.strut-0" style element names where the scene carries block/link and a
// local id, else "strut-E" / "cable-E" with the global index.
std::string element_name(const Structure& scene, int e);

}  // namespace tensegrity::reports
