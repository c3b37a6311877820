#include "cli/exporters.hpp"

#include <iomanip>
#include <sstream>

#include "model/errors.hpp"

namespace tensegrity::cli {

ExportFormat export_format_from_string(const std::string& name) {
  if (name == "vtk") return ExportFormat::Vtk;
  if (name == "obj") return ExportFormat::Obj;
  if (name == "ply") return ExportFormat::Ply;
  throw InputError("command line", "--format", "must be vtk, obj or ply (got '" + name + "')");
}

std::string export_lines(const Structure& scene, const Eigen::Matrix3Xd& x, const Eigen::VectorXd& forces,
                         ExportFormat format) {
  std::ostringstream out;
  out << std::setprecision(17);
  const int n = static_cast<int>(x.cols()), m = scene.num_elements();
  auto kind = [&](int e) { return scene.elements[e].kind == ElementKind::Strut ? 0 : 1; };
  switch (format) {
    case ExportFormat::Vtk:
      out << "# vtk DataFile Version 3.0\n" << scene.name << " (tensegrity)\nASCII\nDATASET POLYDATA\n";
      out << "POINTS " << n << " double\n";
      for (int i = 0; i < n; ++i) out << x(0, i) << " " << x(1, i) << " " << x(2, i) << "\n";
      out << "LINES " << m << " " << 3 * m << "\n";
      for (const auto& e : scene.elements) out << "2 " << e.a << " " << e.b << "\n";
      out << "CELL_DATA " << m << "\nSCALARS force double 1\nLOOKUP_TABLE default\n";
      for (int e = 0; e < m; ++e) out << forces[e] << "\n";
      out << "SCALARS kind int 1\nLOOKUP_TABLE default\n";
      for (int e = 0; e < m; ++e) out << kind(e) << "\n";
      out << "POINT_DATA " << n << "\nSCALARS fixed int 1\nLOOKUP_TABLE default\n";
      for (int i = 0; i < n; ++i) out << (scene.fixed[i] ? 1 : 0) << "\n";
      break;
    case ExportFormat::Ply:
      out << "ply\nformat ascii 1.0\ncomment " << scene.name << " (tensegrity; force in N, kind 0 strut 1 cable)\n";
      out << "element vertex " << n << "\nproperty double x\nproperty double y\nproperty double z\n";
      out << "element edge " << m
          << "\nproperty int vertex1\nproperty int vertex2\nproperty double force\nproperty uchar kind\nend_header\n";
      for (int i = 0; i < n; ++i) out << x(0, i) << " " << x(1, i) << " " << x(2, i) << "\n";
      for (int e = 0; e < m; ++e)
        out << scene.elements[e].a << " " << scene.elements[e].b << " " << forces[e] << " " << kind(e) << "\n";
      break;
    case ExportFormat::Obj:
      out << "# " << scene.name << " (tensegrity): lines, force (N) of each in the comment before it\n";
      for (int i = 0; i < n; ++i) out << "v " << x(0, i) << " " << x(1, i) << " " << x(2, i) << "\n";
      for (int k = 0; k < 2; ++k) {
        out << "g " << (k == 0 ? "struts" : "cables") << "\n";
        for (int e = 0; e < m; ++e) {
          if (kind(e) != k) continue;
          out << "# element " << e << " force " << forces[e] << "\n";
          out << "l " << scene.elements[e].a + 1 << " " << scene.elements[e].b + 1 << "\n";
        }
      }
      break;
  }
  return out.str();
}

}  // namespace tensegrity::cli
