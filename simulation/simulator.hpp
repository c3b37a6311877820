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

struct SimulationOptions {
  double time_step = 1.0 / 60.0;  // h (s)
  double mass_damping = 0.0;      // alpha (1/s)
  double stiffness_damping = 0.0; // beta (s)
  // Newton stops when max |dPhi/dx| <= tolerance * model force scale.
  double tolerance = 1e-9;
  int max_newton_iterations = 50;
  bool exact_hessian_when_definite = true;  // false: always the definite Hessian
};

struct StepReport {
  bool converged = false;
  int newton_iterations = 0;
  int definite_fallbacks = 0;   // iterations that needed the definite Hessian
  double gradient_norm = 0.0;   // max |dPhi/dx| at the end (N)
  double seconds = 0.0;
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
  double merit(const Eigen::Matrix3Xd& x) const;
  double merit_gradient(const Eigen::Matrix3Xd& x, Eigen::VectorXd& g) const;

  ElasticEnergy energy_;
  SimulationOptions options_;
  Eigen::Matrix3Xd x_, v_;
  double time_ = 0.0;
  std::vector<DragSpring> drags_;
  // Per-step workspace, sized once.
  Eigen::Matrix3Xd x_prev_, x_inertial_, trial_;
  Eigen::VectorXd mass_dof_, gradient_, step_, damping_dx_;
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
