#pragma once
// The design pipeline shared by `tensegrity design` and `tensegrity serve`:
// form finding when the input is not yet a tensegrity, stiffness scaling (the
// QP of formulations/stiffness_qp.hpp: cable forces as close as possible to the
// material's force at the target strain, within its measured range) and rest
// lengths (design/rest_lengths.hpp), then verification.
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "design/rest_lengths.hpp"
#include "model/design.hpp"
#include "model/structure.hpp"
#include "solvers/solver.hpp"

namespace tensegrity::reports {

// The 2 mm cord: the 1 mm one carries the duck but neither the scorpion nor the
// puppy (docs/CHARACTERS.md).
inline constexpr const char* kDefaultMaterial = "elastic-cord-2mm";

struct DesignRequest {
  std::string material = kDefaultMaterial;  // name or file, for cables without their own
  std::vector<std::string> material_dirs;   // extra folders to find NAME.json in
  double strain = 0.3;                      // target cable strain
  double naive_fraction = std::nan("");     // set: the constant-fraction baseline instead
  double tol = 1e-8;                        // relative residual of form finding and verification
  double time_limit = 120.0;                // form-finding budget (s)
  std::string options_source = "command line";  // names the options in InputError messages
  bool quiet = false;                       // no informational lines on stderr
};

struct DesignOutcome {
  bool ok = false;  // false: valid input but no buildable design (failure_* say why)
  Design design;
  RestLengthDesign rest;
  std::pair<double, double> strain_range{NAN, NAN};  // smallest and largest cable strain
  std::string failure_item, failure_reason;
};

// Scenes, characters (assembled on the fly) and earlier designs are accepted.
Structure read_design_input(const std::string& path);

// NAME as a file, else NAME.json in `extra_dirs`, $TENSEGRITY_DATA/materials,
// ./data/materials and data/materials beside or above the program.
CableMaterial find_material(const std::string& name, const std::vector<std::string>& extra_dirs,
                            const std::string& item);

// InputError when the strain or the naive fraction is out of range.
void check_design_request(const DesignRequest& req);

// Runs the pipeline on `scene`; `input` names it in messages. Bad options or
// materials throw InputError; an input without a buildable design returns ok = false.
DesignOutcome design_structure(const Structure& scene, const std::string& input, const DesignRequest& req,
                               const Solver& solver);

}  // namespace tensegrity::reports
