#include "cli/link_suggestion_report.hpp"

#include "model/errors.hpp"

namespace tensegrity::cli {

namespace {
nlohmann::json link_candidate_json(const LinkCandidate& c) {
  nlohmann::json j = {{"type", c.type}, {"a", c.a}, {"b", c.b}, {"status", c.status}, {"measured", c.measured},
                      {"link", c.link}, {"geometry_change", c.geometry_change}};
  if (c.measured) {
    const auto& p = c.stiffness.principal;
    nlohmann::json axes = nlohmann::json::array();
    for (int k = 0; k < 3; ++k)
      axes.push_back({c.stiffness.principal_axes(0, k), c.stiffness.principal_axes(1, k), c.stiffness.principal_axes(2, k)});
    j["principal_stiffness"] = {p[0], p[1], p[2]};
    j["principal_axes"] = axes;
    j["anisotropy"] = c.stiffness.anisotropy;
    j["about_axis"] = c.about_axis;
    j["perpendicular"] = c.perpendicular;
    j["torque_for_range"] = c.torque_for_range;
    j["score"] = c.score;
  }
  return j;
}
}  // namespace

CheckedLinkSettings check_link_settings(const SuggestLinkSettings& s) {
  if (s.stiff == !s.axis.empty()) throw InputError("command line", "suggest-link", "give either --axis X Y Z or --stiff");
  if (s.faces < 1 || s.cables < 0) throw InputError("command line", "--faces", "must be >= 1 (cables >= 0)");
  if (!(s.cable_ea > 0.0)) throw InputError("command line", "--cable-ea", "must be > 0");
  CheckedLinkSettings checked;
  checked.request.stiff = s.stiff;
  checked.request.range_deg = s.range_deg;
  if (!s.stiff) {
    if (s.axis.size() != 3) throw InputError("command line", "--axis", "expected 3 numbers X Y Z");
    checked.request.axis = Eigen::Vector3d(s.axis[0], s.axis[1], s.axis[2]);
    if (!checked.request.axis.allFinite() || checked.request.axis.norm() == 0.0)
      throw InputError("command line", "--axis", "must be a finite nonzero vector");
  }
  checked.options.faces_per_block = s.faces;
  checked.options.cables_per_block = s.cables;
  checked.options.solver = s.solver;
  checked.options.stiffness.cable_ea = s.cable_ea;
  return checked;
}

nlohmann::json link_suggestions_json(const std::vector<LinkCandidate>& ranked, const std::string& character,
                                     const std::string& block_a, const std::string& block_b) {
  nlohmann::json out = {{"format", "tensegrity-link-suggestions"}, {"version", 1},
                        {"character", character}, {"a", block_a}, {"b", block_b},
                        {"units", "N m / rad (rotational stiffness), N m (torque)"},
                        {"candidates", nlohmann::json::array()}};
  for (const auto& c : ranked) out["candidates"].push_back(link_candidate_json(c));
  return out;
}

}  // namespace tensegrity::cli
