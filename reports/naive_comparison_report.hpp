#pragma once
// How `tensegrity design --compare-naive` shows the settling comparison
// (design/naive_sweep.hpp): a table for standard error and a record for the
// design file's "design" key.
#include <string>

#include <nlohmann/json.hpp>

#include "design/naive_sweep.hpp"

namespace tensegrity::reports {

// Lines "design: ..." for standard error, ending with the verdict.
std::string naive_comparison_table(const NaiveComparison& c, SettleMethod method);
// {"format": "tensegrity-naive-comparison", "version": 1, "method", "designed": {...},
//  "naive": [{fraction, in_material_range, ...}], "best_fraction"}.
nlohmann::json naive_comparison_json(const NaiveComparison& c, SettleMethod method);

}  // namespace tensegrity::reports
