#include "cli/mjcf.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <vector>

#include "model/errors.hpp"

namespace tensegrity::cli {

namespace {

constexpr double kMinimumBodyMass = 1e-4;  // kg: MuJoCo needs mass on every free body

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string vec(const Eigen::Vector3d& v) { return num(v.x()) + " " + num(v.y()) + " " + num(v.z()); }

std::string xml_name(const std::string& s) {
  std::string out;
  for (char c : s) out += (c == '"' || c == '<' || c == '>' || c == '&') ? '_' : c;
  return out;
}

}  // namespace

std::string write_mjcf(const Design& d, const MjcfOptions& o) {
  const Structure& s = d.structure;
  const Eigen::Matrix3Xd& x = d.solution.positions;
  const int n = s.num_nodes(), m = s.num_elements();
  const Eigen::VectorXd lumped = s.lumped_mass();

  // Which body carries each node: the first strut touching it; others connect to it.
  std::vector<std::vector<int>> struts_at(n);
  std::vector<int> struts;
  for (int e = 0; e < m; ++e)
    if (s.elements[e].kind == ElementKind::Strut) {
      struts_at[s.elements[e].a].push_back(e);
      struts_at[s.elements[e].b].push_back(e);
      struts.push_back(e);
    }
  // Each node's lumped mass (its own, half of every touching cable's and
  // strut's) minus the halves of its struts, shared among its struts as point
  // masses at the node; the strut's own mass is the capsule's.
  std::vector<double> node_share(n, 0.0);
  for (int i = 0; i < n; ++i) {
    if (struts_at[i].empty()) continue;
    double extra = lumped[i];
    for (int e : struts_at[i]) extra -= 0.5 * s.elements[e].mass;
    node_share[i] = std::max(0.0, extra) / static_cast<double>(struts_at[i].size());
  }
  double total_mass = 0.0;
  int bodies = 0;
  for (int e : struts) {
    total_mass += std::max(kMinimumBodyMass, s.elements[e].mass) + node_share[s.elements[e].a] + node_share[s.elements[e].b];
    ++bodies;
  }
  for (int i = 0; i < n; ++i)
    if (struts_at[i].empty() && !s.fixed[i]) total_mass += std::max(kMinimumBodyMass, lumped[i]), ++bodies;
  const double mean_mass = bodies > 0 ? total_mass / bodies : kMinimumBodyMass;

  double ground_z = 1e300;
  for (int i = 0; i < n; ++i)
    if (s.fixed[i]) ground_z = std::min(ground_z, x(2, i));

  std::ostringstream out;
  out << "<!-- MuJoCo model of the tensegrity design '" << xml_name(s.name) << "', written by tensegrity.\n"
      << "     SI units. Bodies: one per strut. Tendons: one per cable (springlength = designed rest length,\n"
      << "     stiffness = secant stiffness F/(l-L) of the cord at the design). -->\n";
  out << "<mujoco model=\"" << xml_name(s.name) << "\">\n"
      << "  <compiler angle=\"radian\"/>\n"
      << "  <option timestep=\"" << num(o.timestep) << "\" gravity=\"" << vec(s.gravity) << "\"/>\n"
      << "  <worldbody>\n";
  if (ground_z < 1e299)
    out << "    <geom name=\"ground\" type=\"plane\" size=\"0 0 1\" pos=\"0 0 " << num(ground_z - o.foot_radius)
        << "\" friction=\"" << num(o.friction) << " 0.005 0.0001\" rgba=\"0.8 0.8 0.8 1\"/>\n";
  // Fixed nodes on no strut are anchored to the world.
  for (int i = 0; i < n; ++i)
    if (struts_at[i].empty() && s.fixed[i]) out << "    <site name=\"n" << i << "\" pos=\"" << vec(x.col(i)) << "\"/>\n";
  std::vector<int> owner(n, -1);
  for (int e : struts) {
    const Element& el = s.elements[e];
    out << "    <body name=\"strut" << e << "\">\n      <freejoint/>\n"
        << "      <geom type=\"capsule\" fromto=\"" << vec(x.col(el.a)) << " " << vec(x.col(el.b)) << "\" size=\""
        << num(o.strut_radius) << "\" mass=\"" << num(std::max(kMinimumBodyMass, el.mass))
        << "\" contype=\"0\" conaffinity=\"0\" rgba=\"0.15 0.2 0.45 1\"/>\n";
    for (int i : {el.a, el.b}) {
      const bool first = owner[i] < 0;
      if (first) owner[i] = e;
      out << "      <site name=\"" << (first ? "n" + std::to_string(i) : "n" + std::to_string(i) + "_s" + std::to_string(e))
          << "\" pos=\"" << vec(x.col(i)) << "\"/>\n";
      if (first && s.fixed[i])
        out << "      <geom type=\"sphere\" pos=\"" << vec(x.col(i)) << "\" size=\"" << num(o.foot_radius)
            << "\" mass=\"" << num(node_share[i]) << "\" friction=\"" << num(o.friction)
            << " 0.005 0.0001\" rgba=\"0 0 0 1\"/>\n";
      else if (node_share[i] > 0)
        out << "      <geom type=\"sphere\" pos=\"" << vec(x.col(i)) << "\" size=\"" << num(o.strut_radius)
            << "\" mass=\"" << num(node_share[i]) << "\" contype=\"0\" conaffinity=\"0\"/>\n";
    }
    out << "    </body>\n";
  }
  for (int i = 0; i < n; ++i)
    if (struts_at[i].empty() && !s.fixed[i])
      out << "    <body name=\"node" << i << "\">\n      <freejoint/>\n      <geom type=\"sphere\" pos=\""
          << vec(x.col(i)) << "\" size=\"" << num(o.strut_radius) << "\" mass=\""
          << num(std::max(kMinimumBodyMass, lumped[i])) << "\" contype=\"0\" conaffinity=\"0\"/>\n      <site name=\"n"
          << i << "\" pos=\"" << vec(x.col(i)) << "\"/>\n    </body>\n";
  out << "  </worldbody>\n";

  const auto materials = d.material_pointers();
  out << "  <tendon>\n";
  for (int e = 0; e < m; ++e) {
    const Element& el = s.elements[e];
    if (el.kind != ElementKind::Cable) continue;
    const double l = (x.col(el.a) - x.col(el.b)).norm();
    const double L = (*d.solution.rest_lengths)[e];
    const double F = d.solution.forces[e];
    const double eps = l / L - 1.0;
    const double tangent = materials[e] != nullptr ? materials[e]->slope_unchecked(eps) / L : 0.0;
    double k = l - L > 1e-12 * L ? F / (l - L) : tangent;
    if (!(k > 0) || !std::isfinite(k))
      throw InputError(s.name, "element " + std::to_string(e), "cable without a positive stiffness for MuJoCo");
    const double damping = o.damping_ratio * 2.0 * std::sqrt(k * mean_mass);
    out << "    <spatial name=\"cable" << e << "\" springlength=\"" << num(L) << "\" stiffness=\"" << num(k)
        << "\" damping=\"" << num(damping) << "\" width=\"0.0008\" rgba=\"0.7 0.1 0.1 1\">"
        << "<!-- force " << num(F) << " N, tangent stiffness " << num(tangent) << " N/m -->\n"
        << "      <site site=\"n" << el.a << "\"/>\n      <site site=\"n" << el.b << "\"/>\n    </spatial>\n";
  }
  out << "  </tendon>\n";
  // Stiff equality constraints: soft ones let a shared node or a support
  // give way under the prestress.
  const std::string stiff = "\" solref=\"" + num(o.constraint_time_constant) + " 1\" solimp=\"0.99 0.999 0.0001\"/>\n";
  std::ostringstream equality;
  for (int i = 0; i < n; ++i) {
    for (std::size_t k = 1; k < struts_at[i].size(); ++k)
      equality << "    <connect body1=\"strut" << struts_at[i][0] << "\" body2=\"strut" << struts_at[i][k]
               << "\" anchor=\"" << vec(x.col(i)) << stiff;
    if (s.fixed[i] && !struts_at[i].empty() && o.pin_fixed_nodes)
      equality << "    <connect body1=\"strut" << struts_at[i][0] << "\" anchor=\"" << vec(x.col(i)) << stiff;
  }
  if (!equality.str().empty()) out << "  <equality>\n" << equality.str() << "  </equality>\n";
  out << "</mujoco>\n";
  return out.str();
}

}  // namespace tensegrity::cli
