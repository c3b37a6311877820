#include "reports/exporters.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "reports/canvas.hpp"
#include "model/errors.hpp"

namespace tensegrity::reports {

namespace {

// Blue (compression) - light grey (zero) - red (tension), t in [-1, 1].
Eigen::Vector3d force_colour(double t) {
  const Eigen::Vector3d grey(0.8, 0.8, 0.8), blue(0.05, 0.2, 0.75), red(0.75, 0.05, 0.05);
  t = std::clamp(t, -1.0, 1.0);
  return t < 0 ? Eigen::Vector3d(grey + (-t) * (blue - grey)) : Eigen::Vector3d(grey + t * (red - grey));
}

std::string json_text(const nlohmann::json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); }

}  // namespace

ExportFormat export_format_from_string(const std::string& name) {
  if (name == "vtk") return ExportFormat::Vtk;
  if (name == "obj") return ExportFormat::Obj;
  if (name == "ply") return ExportFormat::Ply;
  if (name == "ntrt-yaml") return ExportFormat::NtrtYaml;
  if (name == "mjcf") return ExportFormat::Mjcf;
  throw InputError("command line", "--format", "must be vtk, obj, ply, ntrt-yaml or mjcf (got '" + name + "')");
}

ExportFormat export_format_for(const std::string& path, const std::string& format) {
  if (!format.empty()) return export_format_from_string(format);
  if (ends_with(path, ".vtk")) return ExportFormat::Vtk;
  if (ends_with(path, ".obj")) return ExportFormat::Obj;
  if (ends_with(path, ".ply")) return ExportFormat::Ply;
  if (ends_with(path, ".yaml") || ends_with(path, ".yml")) return ExportFormat::NtrtYaml;
  if (ends_with(path, ".xml")) return ExportFormat::Mjcf;
  throw InputError("command line", "--out " + path,
                   "unknown extension (.vtk, .obj, .ply, .yaml, .mjcf.xml); name the format with --format");
}

std::string element_name(const Structure& scene, int e) {
  const char* kind = scene.elements[e].kind == ElementKind::Strut ? "strut" : "cable";
  const nlohmann::json extra =
      e < static_cast<int>(scene.element_extra.size()) ? scene.element_extra[e] : nlohmann::json::object();
  if (extra.contains("block")) {
    if (extra.contains("name")) return json_text(extra["block"]) + "." + json_text(extra["name"]);
    if (extra.contains("block_element"))
      return json_text(extra["block"]) + "." + kind + "-" + json_text(extra["block_element"]);
  }
  if (extra.contains("link")) {
    int local = 0;
    for (int k = 0; k < e; ++k)
      if (k < static_cast<int>(scene.element_extra.size()) && scene.element_extra[k].contains("link") &&
          scene.element_extra[k]["link"] == extra["link"])
        ++local;
    return json_text(extra["link"]) + "." + kind + "-" + std::to_string(local);
  }
  if (extra.contains("name")) return json_text(extra["name"]);
  return std::string(kind) + "-" + std::to_string(e);
}

std::string element_forces_csv(const Structure& scene, const Eigen::VectorXd& forces) {
  std::ostringstream out;
  out << std::setprecision(17) << "element,name,kind,node_a,node_b,force_N\n";
  for (int e = 0; e < scene.num_elements(); ++e) {
    std::string name = element_name(scene, e);
    if (name.find_first_of(",\"") != std::string::npos) name = "\"" + name + "\"";
    out << e << ',' << name << ',' << to_string(scene.elements[e].kind) << ',' << scene.elements[e].a << ','
        << scene.elements[e].b << ',' << forces[e] << '\n';
  }
  return out.str();
}

std::string export_lines(const Structure& scene, const Eigen::Matrix3Xd& x, const Eigen::VectorXd& forces,
                         ExportFormat format, const std::string& title) {
  std::ostringstream out;
  out << std::setprecision(17);
  const int n = static_cast<int>(x.cols()), m = scene.num_elements();
  auto kind = [&](int e) { return scene.elements[e].kind == ElementKind::Strut ? 0 : 1; };
  switch (format) {
    case ExportFormat::Vtk:
      out << "# vtk DataFile Version 3.0\n" << (title.empty() ? scene.name + " (tensegrity)" : title)
          << "\nASCII\nDATASET POLYDATA\n";
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
    case ExportFormat::Obj: {
      const double largest_force = forces.size() > 0 ? forces.cwiseAbs().maxCoeff() : 0.0;
      const double largest = largest_force > 0.0 ? largest_force : 1.0;  // no forces: every element grey
      out << "# " << scene.name << " (tensegrity): one line per element, its two vertices coloured by its force\n";
      if (largest_force > 0.0) {
        out << "# (blue compression, grey zero, red tension; full colour at " << largest
            << " N); forces in the companion .forces.csv\n";
      } else {
        out << "# (no forces: every element grey); forces in the companion .forces.csv\n";
      }
      for (int e = 0; e < m; ++e) {
        const Eigen::Vector3d c = force_colour(forces[e] / largest);
        for (int i : {scene.elements[e].a, scene.elements[e].b})
          out << "v " << x(0, i) << " " << x(1, i) << " " << x(2, i) << " " << std::setprecision(4) << c.x() << " "
              << c.y() << " " << c.z() << std::setprecision(17) << "\n";
      }
      for (int k = 0; k < 2; ++k) {
        out << "g " << (k == 0 ? "struts" : "cables") << "\n";
        for (int e = 0; e < m; ++e)
          if (kind(e) == k) out << "l " << 2 * e + 1 << " " << 2 * e + 2 << "\n";
      }
      break;
    }
    case ExportFormat::NtrtYaml:
    case ExportFormat::Mjcf:
      throw InputError("command line", "--format", "not a line format");
  }
  return out.str();
}

}  // namespace tensegrity::reports
