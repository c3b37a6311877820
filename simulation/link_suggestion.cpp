#include "simulation/link_suggestion.hpp"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "model/character.hpp"
#include "model/errors.hpp"
#include "model/status.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {

namespace {

const nlohmann::json& block_entry(const nlohmann::json& character, const std::string& source, const std::string& id) {
  if (character.contains("blocks") && character["blocks"].is_array())
    for (const auto& jb : character["blocks"])
      if (jb.is_object() && jb.value("id", "") == id) return jb;
  throw InputError(source, "blocks", "no block with id '" + id + "'");
}

std::vector<int> nodes_of_block(const Structure& s, const std::string& id) {
  std::vector<int> out;
  for (int i = 0; i < s.num_nodes(); ++i)
    if (s.node_extra[i].value("block", "") == id && !s.node_extra[i].contains("link")) out.push_back(i);
  return out;
}

Eigen::Vector3d centroid_of(const Structure& s, const std::vector<int>& nodes) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int i : nodes) c += s.positions.col(i);
  return c / static_cast<double>(nodes.size());
}

// Names of the k faces (or cables) of block `id` in the built pair `s` that
// face (lie nearest) the other block.
std::vector<std::string> facing_faces(const Structure& s, const Block& block, const std::vector<int>& map,
                                      const Eigen::Vector3d& own, const Eigen::Vector3d& other, int k) {
  std::vector<std::pair<double, std::string>> scored;
  const Eigen::Vector3d dir = (other - own).normalized();
  for (const auto& [name, f] : block.faces) {
    const Eigen::Vector3d a = s.positions.col(map[f[0]]), b = s.positions.col(map[f[1]]),
                          c = s.positions.col(map[f[2]]);
    Eigen::Vector3d nrm = (b - a).cross(c - a).normalized();
    if (nrm.dot((a + b + c) / 3.0 - own) < 0.0) nrm = -nrm;
    scored.emplace_back(-nrm.dot(dir), name);
  }
  std::sort(scored.begin(), scored.end());
  std::vector<std::string> out;
  for (int i = 0; i < std::min<int>(k, scored.size()); ++i) out.push_back(scored[i].second);
  return out;
}

std::vector<std::string> nearest_cables(const Structure& s, const Block& block, const std::vector<int>& map,
                                        const Eigen::Vector3d& other, int k) {
  std::vector<std::pair<double, std::string>> scored;
  for (const auto& [name, e] : block.cables) {
    const auto& el = block.structure.elements[e];
    const Eigen::Vector3d mid = 0.5 * (s.positions.col(map[el.a]) + s.positions.col(map[el.b]));
    scored.emplace_back((mid - other).norm(), name);
  }
  std::sort(scored.begin(), scored.end());
  std::vector<std::string> out;
  for (int i = 0; i < std::min<int>(k, scored.size()); ++i) out.push_back(scored[i].second);
  return out;
}

double smaller_perpendicular(const Eigen::Matrix3d& S, const Eigen::Vector3d& w) {
  Eigen::Vector3d p = w.unitOrthogonal(), q = w.cross(p);
  Eigen::Matrix2d P;
  P << p.dot(S * p), p.dot(S * q), q.dot(S * p), q.dot(S * q);
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(P).eigenvalues()[0];
}

}  // namespace

nlohmann::json two_block_character(const nlohmann::json& character, const std::string& source,
                                   const std::string& block_a, const std::string& block_b,
                                   const nlohmann::json& link) {
  nlohmann::json j = {{"format", "tensegrity-character"},
                      {"version", 1},
                      {"name", block_a + "+" + block_b},
                      {"gravity", {0.0, 0.0, 0.0}},
                      {"blocks", {block_entry(character, source, block_a), block_entry(character, source, block_b)}},
                      {"links", nlohmann::json::array()}};
  if (!link.is_null()) j["links"].push_back(link);
  return j;
}

std::vector<LinkCandidate> suggest_links(const nlohmann::json& character, const std::string& source,
                                         const BlockLibrary& library, const std::string& block_a,
                                         const std::string& block_b, const LinkRequest& request,
                                         const LinkSuggestionOptions& options) {
  // The unlinked pair, to pick candidate faces and cables.
  const BuiltCharacter pair = build_character(two_block_character(character, source, block_a, block_b, nullptr),
                                              source, library);
  const std::vector<int> na = nodes_of_block(pair.structure, block_a), nb = nodes_of_block(pair.structure, block_b);
  const Eigen::Vector3d ca = centroid_of(pair.structure, na), cb = centroid_of(pair.structure, nb);
  const Block& ba = library.get(block_entry(character, source, block_a).value("type", ""), source, "type");
  const Block& bb = library.get(block_entry(character, source, block_b).value("type", ""), source, "type");
  std::vector<int> map_a(na.begin(), na.begin() + ba.structure.num_nodes());
  std::vector<int> map_b(nb.begin(), nb.begin() + bb.structure.num_nodes());

  std::vector<nlohmann::json> links;
  for (const auto& fa : facing_faces(pair.structure, ba, map_a, ca, cb, options.faces_per_block))
    for (const auto& fb : facing_faces(pair.structure, bb, map_b, cb, ca, options.faces_per_block))
      links.push_back({{"id", "candidate"}, {"type", "face"}, {"a", {{"block", block_a}, {"face", fa}}},
                       {"b", {{"block", block_b}, {"face", fb}}}});
  for (const auto& ea : nearest_cables(pair.structure, ba, map_a, cb, options.cables_per_block))
    for (const auto& eb : nearest_cables(pair.structure, bb, map_b, ca, options.cables_per_block))
      links.push_back({{"id", "candidate"}, {"type", "edge"}, {"a", {{"block", block_a}, {"cable", ea}}},
                       {"b", {{"block", block_b}, {"cable", eb}}}});

  const auto solver = make_solver(options.solver.empty() ? default_solver_name() : options.solver);
  const Eigen::Vector3d w = request.axis.normalized();
  std::vector<LinkCandidate> out;
  for (const auto& link : links) {
    LinkCandidate c;
    c.type = link["type"];
    const char* key = c.type == "face" ? "face" : "cable";
    c.a = link["a"][key];
    c.b = link["b"][key];
    c.link = link;
    Structure s;
    try {
      s = build_character(two_block_character(character, source, block_a, block_b, link), source, library).structure;
    } catch (const InputError& e) {
      c.status = std::string("not buildable: ") + e.what();
      out.push_back(c);
      continue;
    }
    SolveOptions so;
    const SolveResult r = solve_scene(*solver, s, so);
    c.status = std::string(to_string(r.status));
    c.geometry_change = r.stats.geometry_change;
    if (r.status == Status::Converged) {
      double cable_sum = 0.0;
      int cables = 0;
      for (int e = 0; e < s.num_elements(); ++e)
        if (s.elements[e].kind == ElementKind::Cable) {
          cable_sum += r.forces[e];
          ++cables;
        }
      const Eigen::VectorXd forces = r.forces * (cables / cable_sum);
      c.stiffness = relative_rotation_stiffness(s, r.positions, forces, nodes_of_block(s, block_a),
                                                nodes_of_block(s, block_b), options.stiffness);
      c.measured = c.stiffness.positive_definite;
      c.about_axis = c.stiffness.about(w);
      c.perpendicular = smaller_perpendicular(c.stiffness.rotation, w);
      c.torque_for_range = c.about_axis * request.range_deg * M_PI / 180.0;
      c.score = request.stiff ? -c.stiffness.principal[0] : c.about_axis / c.perpendicular;
    }
    out.push_back(c);
  }
  std::stable_sort(out.begin(), out.end(), [](const LinkCandidate& x, const LinkCandidate& y) {
    if (x.measured != y.measured) return x.measured;
    return x.score < y.score;
  });
  return out;
}

}  // namespace tensegrity
