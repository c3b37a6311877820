#pragma once
// Actuation: which few cables or struts, changed in rest length, move a
// character into desired poses (paper, section 6: "computing minimal sets of
// actuation elements that are able to generate a desired range of motions").
//
// The character is an elastic model (formulations/elastic_energy.hpp) at its
// static equilibrium x0 under gravity. A pose asks target positions t for some
// nodes. Linearised kinematics: equilibrium grad_x E(x, L) = 0, so
//   K dx = -sum_e (d sigma_e / d L_e) (d l_e / d x) dL_e,
//   d sigma_e / d L_e = -f_e'(eps_e) l_e / L_e^2          (sigma_e = f_e(l_e / L_e - 1)),
// with K the Hessian of E over the free coordinates; J_p = rows of dx/dL at
// the target coordinates of pose p (m per m of rest length).
// A cable whose rest length passes its length goes slack (its column of dx/dL
// vanishes), so a cable's lengthening is bounded by its stretch l - L.
// Selection (simultaneous orthogonal matching pursuit over all poses): the
// element whose column, with that bound, most lowers the remaining squared
// residuals of all poses joins the set; each pose gets its own bounded
// least-squares rest-length changes on the set (the linear prediction). Then
// for each set size, a Gauss-Newton on the nonlinear model: rest lengths
// L + dL, static relax (simulation/simulator.hpp), residual at the targets, J
// re-linearised at the relaxed state; a step lengthens a chosen cable by at
// most `slack_margin` of its current stretch and is halved until the verified
// residual falls. A level starts from the previous level's reached state, so
// the reached error never grows with the set. Other cables may go slack on
// the way (counted). Every reported error is that of a converged static solve.
//
// Both stages need x0 to be a stable equilibrium (K positive definite): at a
// saddle, K^{-1} is not the response of the structure, and any change of a
// rest length lets the static solve fall away from x0. Linear cords at 10 %
// strain leave a character's struts too little cable stiffness against their
// negative geometric stiffness; find_actuators reports such a start instead of
// stepping.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "formulations/elastic_energy.hpp"

namespace tensegrity {

struct PoseTarget {
  int node = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // m
};

struct Pose {
  std::string name;
  std::vector<PoseTarget> targets;
};

struct ActuationOptions {
  int max_actuators = 6;
  int newton_iterations = 20;
  double max_relative_change = 0.5;  // |dL / L| per step is scaled down to this
  double slack_margin = 0.5;         // fraction of a cable's stretch l - L one step may lengthen it by
  bool cables_only = false;          // struts may also change length when false
};

struct PoseResult {
  std::string name;
  Eigen::VectorXd rest_length_change;  // m, one per chosen element (set order), as reached
  double initial_error = 0.0;          // rms distance to the targets at x0 (m)
  double linear_error = 0.0;           // rms predicted by the linearisation with the slack bounds (m)
  double reached_error = 0.0;          // rms after the nonlinear solve, verified by relax (m)
  double max_error = 0.0;              // largest target distance after the solve (m)
  int steps_accepted = 0;              // Gauss-Newton steps that lowered the verified error
  int cables_slack = 0;                // cables slack in the reached state (none of the chosen ones)
};

struct ActuationLevel {
  std::vector<int> elements;  // chosen elements, in order of selection
  std::vector<PoseResult> poses;
};

struct ActuationResult {
  bool stable_start = false;  // x0 is a stable equilibrium; levels is empty otherwise
  std::string message;        // why not, or the start's smallest stiffness eigenvalue
  std::vector<ActuationLevel> levels;  // one per set size 1..max_actuators (each set extends the previous)
};

ActuationResult find_actuators(const ElasticModel& model, const Eigen::Matrix3Xd& equilibrium,
                                           const std::vector<Pose>& poses, const ActuationOptions& options = {});

// d x / d L at the free coordinates (3 n_free x m) at equilibrium x.
Eigen::MatrixXd rest_length_sensitivity(const ElasticEnergy& energy, const Eigen::Matrix3Xd& x);

}  // namespace tensegrity
