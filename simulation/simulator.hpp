#pragma once
// Dynamic simulation (paper, section 3 "Simulation", Eq. 7) and the static
// relax of a built character, both on the elastic energy E of
// formulations/elastic_energy.hpp.
//
// Implicit Euler, x_{n+1} = x_n + h v_n + h^2 M^{-1} f(x_{n+1}), is solved as
// the minimisation of the incremental potential
//
//   Phi(x) = 1/(2h^2) |x - x_n - h v_n|_M^2                  (inertia)
//          + alpha/(2h) |x - x_n|_M^2                        (mass-proportional damping, alpha in 1/s)
//          + beta/(2h) (x - x_n)^T K_n (x - x_n)            (stiffness-proportional damping, beta in s)
//          + E(x)                                           (elastic + gravity + drags at t_{n+1})
//
// whose stationarity is Eq. 7 with the damping forces -alpha M v - beta K_n v
// (K_n the definite Hessian of E at x_n, fixed for the step); then
// v_{n+1} = (x_{n+1} - x_n) / h. M is the lumped mass (Structure::lumped_mass:
// half of every strut and cable at each end). Fixed nodes never move.
//
// Newton with an Armijo backtracking line search on Phi, the merit function.
// The exact Hessian is used when its LDLT is positive definite; otherwise the
// definite Hessian (HessianMode::Definite: compressed elements' negative
// geometric terms dropped), plus a growing diagonal shift if even that fails,
// so every step descends. One SimplicialLDLT: symbolic analysis once per
// topology, numeric factorisation per iteration. No allocation in the loop
// beyond Eigen's factor values.
//
// Substeps: when a step's Newton solve does not converge (typically a stiff
// drag spring switched on at once: the exact Hessian of Phi is then indefinite
// for many iterations and the definite fallback converges only linearly), the
// step is retried as two implicit-Euler steps of h/2 from the same state,
// recursively, down to h / 2^max_substep_halvings. The step still ends at
// t_n + h, so output frames stay on the requested time grid, and a step that
// converges at once is computed exactly as without this retry. Within a step
// split into substeps, a drag target moves linearly from its target of the
// previous step (if that node was dragged then) to its new one, which is what
// a run at the smaller step sees with piecewise-linear drag targets; a drag
// that starts this step pulls toward its target from the first substep.
// Only when a substep of the smallest size fails is the step reported not
// converged; its best iterate is kept and the step continues.
//
// Energy bookkeeping (used by the tests): with H = kinetic + E, one step
// without damping obeys exactly
//   H_{n+1} - H_n = -1/2 |v_{n+1} - v_n|_M^2 - D_E(x_n, x_{n+1}),
//   D_E(a, b) = E(a) - E(b) - grad E(b) . (a - b)   (a Bregman divergence),
// the numerical dissipation of implicit Euler; step() reports both terms.
#include <Eigen/Core>
#include <Eigen/SparseCholesky>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "formulations/elastic_energy.hpp"
#include "model/status.hpp"

namespace tensegrity {

// Default for SimulationOptions::max_substep_halvings: substeps down to h/16.
// A step whose every level fails costs at most 2^(k+1) - 1 Newton solves.
inline constexpr int kDefaultMaxSubstepHalvings = 4;

struct SimulationOptions {
  double time_step = 1.0 / 60.0;  // h (s)
  double mass_damping = 0.0;      // alpha (1/s)
  double stiffness_damping = 0.0; // beta (s)
  // Newton stops when max |dPhi/dx| <= tolerance * model force scale.
  double tolerance = 1e-9;
  int max_newton_iterations = 50;
  bool exact_hessian_when_definite = true;  // false: always the definite Hessian
  // A failed step is retried as two halves, down to h / 2^max_substep_halvings;
  // 0 turns the retry off (one Newton solve per step, kept even if it fails).
  int max_substep_halvings = kDefaultMaxSubstepHalvings;
};

struct StepReport {
  bool converged = false;       // every substep that makes up the step converged
  int newton_iterations = 0;    // all of them, including those of abandoned solves
  int definite_fallbacks = 0;   // iterations that needed the definite Hessian
  int substeps = 1;             // implicit-Euler steps that make up the step (1: not split)
  int retries = 0;              // Newton solves abandoned and retried as two halves
  double smallest_substep = 0.0;  // s, the shortest substep taken (h when not split)
  double gradient_norm = 0.0;   // max |dPhi/dx| at the end, largest over the substeps (N)
  double seconds = 0.0;
  // Summed over the substeps, so that the step's energy balance below holds.
  double velocity_jump = 0.0;   // 1/2 |v_{n+1} - v_n|_M^2 (J)
  double bregman = 0.0;         // D_E(x_n, x_{n+1}) (J)
};

class Simulator {
 public:
  Simulator(const ElasticModel& model, const Eigen::Vector3d& gravity, const SimulationOptions& options);
  ~Simulator();
  Simulator(Simulator&&) noexcept;

  double time() const { return time_; }
  const Eigen::Matrix3Xd& positions() const { return x_; }
  const Eigen::Matrix3Xd& velocities() const { return v_; }
  void set_state(const Eigen::Matrix3Xd& positions, const Eigen::Matrix3Xd& velocities);
  // Drag springs acting during the next steps (targets at the step's end time).
  void set_drags(std::vector<DragSpring> drags) { drags_ = std::move(drags); }
  const std::vector<DragSpring>& drags() const { return drags_; }

  StepReport step();

  double kinetic_energy() const;   // 1/2 |v|_M^2 (J)
  double potential_energy() const; // E(x) with the current drags (J)
  Eigen::VectorXd element_forces() const { return energy_.element_forces(x_); }
  const ElasticEnergy& energy() const { return energy_; }

 private:
  // One implicit-Euler step of length h from (x_, v_), drags at `drag_fraction`
  // of the way from their previous targets to the current ones; its outcome
  // goes into `report`. x_prev_, v_prev_ keep its start.
  bool newton_step(double h, double drag_fraction, StepReport& report);
  // newton_step, retried as two halves while it fails and halvings remain.
  void advance(double h, int halvings, double fraction_start, double fraction_span, StepReport& report);
  void set_active_drags(double fraction);
  double merit(const Eigen::Matrix3Xd& x) const;
  double merit_gradient(const Eigen::Matrix3Xd& x, Eigen::VectorXd& g) const;
  void free_displacement(const Eigen::Matrix3Xd& x) const;  // dq_ = x - x_prev_ on the free nodes

  ElasticEnergy energy_;
  SimulationOptions options_;
  Eigen::Matrix3Xd x_, v_;
  double time_ = 0.0;
  std::vector<DragSpring> drags_;
  std::vector<DragSpring> previous_drags_;  // the drags of the last step taken
  std::vector<DragSpring> active_drags_;    // the drags of the substep being solved
  std::vector<Eigen::Vector3d> drag_start_targets_;  // targets at the start of the step
  double h_ = 0.0;                          // the substep being solved (s)
  // Per-step workspace, sized once.
  Eigen::Matrix3Xd x_prev_, v_prev_, x_inertial_, trial_;
  Eigen::VectorXd mass_dof_, gradient_, step_, gradient_trial_;
  mutable Eigen::VectorXd dq_, kdq_;
  Eigen::SparseMatrix<double> hessian_, damping_k_;
  std::unique_ptr<Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>> ldlt_;
};

// ---- static relax -------------------------------------------------------------

struct RelaxOptions {
  // max |grad E| <= tolerance * model force scale (N). The stiff struts put the
  // round-off floor of the net force near 1e-10 of it.
  double tolerance = 1e-9;
  int max_iterations = 500;
};

struct RelaxResult {
  Status status = Status::NumericalError;
  std::string message;
  Eigen::Matrix3Xd positions;      // 3 x n
  Eigen::VectorXd forces;          // N per element at the relaxed positions
  int iterations = 0;
  int definite_steps = 0;          // iterations on the definite (or shifted) Hessian
  double gradient_norm = 0.0;      // max net force on a free node (N)
  double energy = 0.0;             // J
  double max_displacement = 0.0;   // m, largest |x_i - reference_i|
  int max_displacement_node = -1;
  double seconds = 0.0;
  int cables_slack = 0;
  int cables_outside_range = 0;
};

// Static equilibrium with rest lengths fixed: min_x E(x) from `start`, by
// Newton (exact Hessian when positive definite, else the definite one with a
// Levenberg shift that grows while the line search fails). Gravity with no
// fixed node and no drag has no minimum: Infeasible without iterating.
RelaxResult relax(const ElasticEnergy& energy, const Eigen::Matrix3Xd& start,
                  std::span<const DragSpring> drags = {}, const RelaxOptions& options = {});

}  // namespace tensegrity
