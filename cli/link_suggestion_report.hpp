#pragma once
// What `tensegrity suggest-link` and `POST /api/suggest-link` share: their
// options checked the same way, and the ranking as JSON
// (format tensegrity-link-suggestions; stiffness in N m / rad, torque in N m).
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "simulation/link_suggestion.hpp"

namespace tensegrity::cli {

struct SuggestLinkSettings {
  std::vector<double> axis;  // empty with stiff; else 3 numbers (world frame)
  double range_deg = 30.0;
  bool stiff = false;
  int faces = 3, cables = 3;
  double cable_ea = 20.0;  // N
  std::string solver;      // empty: the default backend
};

struct CheckedLinkSettings {
  LinkRequest request;
  LinkSuggestionOptions options;
};

// InputError("command line", OPTION, REASON) for settings the command refuses.
CheckedLinkSettings check_link_settings(const SuggestLinkSettings& settings);

// The ranking, best first, as the command's --json file holds it.
nlohmann::json link_suggestions_json(const std::vector<LinkCandidate>& ranked, const std::string& character,
                                     const std::string& block_a, const std::string& block_b);

}  // namespace tensegrity::cli
