#pragma once
// The fabrication sheet of a design: what someone cutting struts and tying
// cables needs, in the order the paper assembles a character.
//
// CSV, lengths in millimetres to 0.1 mm, forces in N to 3 significant digits:
//
//   group_kind,group,element,name,kind,node_a,node_b,material,length_mm,rest_length_mm,force_N,strain,count
//
// One row per element, grouped: every block (in order of first appearance),
// then every link, then elements without a block or link id ("none"); within
// a group struts first, then cables, each in element order. `name` is the
// element's name (block and local id, "body.strut-0"; links "leg-left.cable-2").
// A strut's cut length is its length; a cable is tied at its rest length.
// Then totals: one "total,,,,strut" row (count and summed length of the
// struts) and one "total,,,,cable,,,MATERIAL" row per material (count, summed
// stretched and rest length).
//
// The cut list shows the same rows, each with a bar to scale: as PDF on A4
// pages for printing, or as one tall SVG (or PNG) for the screen.
#include <Eigen/Core>
#include <string>

#include "model/design.hpp"

namespace tensegrity::reports {

// `lengths`: the stretched length of every element at the designed geometry (m).
std::string fabrication_sheet_csv(const Design& d, const Eigen::VectorXd& lengths);
// Writes the cut list to `path` (.pdf on A4 pages, .svg or .png on one).
void write_cut_list(const Design& d, const Eigen::VectorXd& lengths, const std::string& path);

}  // namespace tensegrity::reports
