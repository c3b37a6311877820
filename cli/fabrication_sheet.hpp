#pragma once
// The fabrication sheet of a design (CSV): what someone cutting struts and
// tying cables needs, in the order the paper assembles a character.
//
//   group_kind,group,element,kind,node_a,node_b,material,length_m,rest_length_m,force_N,strain,count
//
// One row per element, grouped: every block (in order of first appearance),
// then every link, then elements without a block or link id ("none"); within
// a group struts first, then cables, each in element order. Then totals: one
// "total,,,strut" row (count and summed length of the struts) and one
// "total,,,cable,,,MATERIAL" row per material (count, summed stretched and
// rest length).
#include <Eigen/Core>
#include <string>

#include "model/design.hpp"

namespace tensegrity::cli {

// `lengths`: the stretched length of every element at the designed geometry (m).
std::string fabrication_sheet_csv(const Design& d, const Eigen::VectorXd& lengths);

}  // namespace tensegrity::cli
