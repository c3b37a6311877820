#pragma once
// Stability of an equilibrium (paper, section 6: unstable equilibria should be
// detected and reported).
//
// 1. Second-order test on the elastic model (formulations/elastic_energy.hpp):
//    the tangent stiffness K = d2E/dx2 (material terms k_e u u^T plus the
//    geometric terms (sigma_e / l_e)(I - u u^T), exact, N/m), reduced to the
//    free coordinates and, when no node is fixed, restricted to the orthogonal
//    complement of the six rigid-body motions. Its smallest eigenvalues decide:
//      stable    lambda_min >  zero_tolerance * scale
//      marginal  |lambda_min| <= zero_tolerance * scale (a zero-stiffness
//                motion: first-order flexible, decided only at higher order)
//      unstable  lambda_min < -zero_tolerance * scale, or the configuration is
//                not an equilibrium (it will move: nothing to be stable about)
//    with scale = the largest diagonal entry of K. Dense SelfAdjointEigenSolver
//    up to dense_limit coordinates; above, shift-invert block Lanczos (full
//    re-orthogonalisation, rigid modes deflated) on one sparse LDLT, with the
//    shift placed below the spectrum by Sylvester's inertia (the number of
//    negative pivots of K - s I is the number of eigenvalues below s).
//
// 2. Prestress stability and super stability of a self-stressed framework
//    (Connelly): with force densities omega_e = sigma_e / l_e, the n x n
//    force-density (stress) matrix Omega (Omega_ij = -omega_ij, rows sum to 0):
//      super stable     Omega PSD, nullity d + 1 = 4, and the member
//                       directions do not lie on a conic at infinity (no
//                       nonzero symmetric Q with u_e^T Q u_e = 0 for all e,
//                       i.e. the m x 6 matrix of u u^T entries has rank 6);
//      prestress stable Omega (x) I_3 positive definite on the non-trivial
//                       first-order flexes (kernel of the rigidity matrix,
//                       rigid motions removed); implied by super stability.
//    Fixed nodes are ignored there (the test is for free-standing blocks).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "formulations/elastic_energy.hpp"

namespace tensegrity {

enum class Stability { Stable, Marginal, Unstable };
const char* to_string(Stability s);

struct StabilityOptions {
  int num_eigenvalues = 6;
  double zero_tolerance = 1e-10;       // relative to the largest diagonal of K
  double equilibrium_tolerance = 1e-6; // max net force / model force scale
  int dense_limit = 1500;              // free coordinates up to which the dense solver is used
  bool force_lanczos = false;          // use Lanczos whatever the size (tests)
};

struct StabilityReport {
  Stability verdict = Stability::Unstable;
  std::vector<double> eigenvalues;     // smallest of the reduced K, ascending (N/m)
  double scale = 0.0;                  // largest diagonal of K (N/m)
  int dofs = 0;                        // coordinates analysed (after removing rigid modes)
  int rigid_modes_removed = 0;
  int zero_modes = 0;                  // among the computed eigenvalues
  int negative_modes = 0;              // exact count (inertia), N/m below -tolerance
  bool in_equilibrium = false;
  double relative_residual = 0.0;      // max net force / model force scale
  std::string method;                  // "dense" or "lanczos"
  std::string message;
};

// The test at x (normally an equilibrium found by relax or by design).
StabilityReport analyze_stability(const ElasticEnergy& energy, const Eigen::Matrix3Xd& x,
                                  const StabilityOptions& options = {});

struct PrestressReport {
  bool omega_psd = false;
  int omega_nullity = 0;
  double omega_smallest_nonzero = 0.0;  // N/m
  int direction_rank = 0;               // rank of the member-direction conic matrix (6 needed)
  bool super_stable = false;
  int flexes = 0;                       // non-trivial first-order flexes
  double min_flex_stiffness = 0.0;      // smallest eigenvalue of Omega (x) I on the flexes (N/m)
  bool prestress_stable = false;
  std::string message;
};

PrestressReport prestress_stability(const Structure& s, const Eigen::Matrix3Xd& x, const Eigen::VectorXd& forces,
                                    double tolerance = 1e-9);

}  // namespace tensegrity
