#pragma once
// Private to the stress-QP kernel (kernels/stress_qp*.cpp): the per-topology
// data, the state of one solve, and the phases that act on them.
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <limits>
#include <memory>
#include <vector>

#include "kernels/normal_matrix.hpp"
#include "kernels/pattern_ldlt.hpp"
#include "kernels/stress_qp.hpp"

namespace tensegrity {
namespace stress_qp_detail {

using SparseMatrix = Eigen::SparseMatrix<double>;
inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr double kEps = std::numeric_limits<double>::epsilon();

// Iterative refinement of a solve with K against the operator it approximates.
struct RefinementConstants {
  // Stop at this many eps times |b|, or when a refinement contracts the
  // residual by less than this factor (rounding level reached).
  static constexpr double kRoundingFactor = 4.0;
  static constexpr double kSlowestContraction = 0.5;
};

// Projected Newton with an active set.
struct ProjectedNewtonConstants {
  // Rounds of pinning forces whose Newton component leaves the box (one
  // factorization each).
  static constexpr int kPinRounds = 5;
  // Non-monotone full steps a cold start may take from a new best point.
  static constexpr int kNonmonotoneSteps = 8;
  // StressQpOptions::end_when_stalled_after: the least relative fall of the
  // best objective that counts as progress.
  static constexpr double kStalledImprovement = 1e-3;
  // Sufficient-decrease fraction of the Armijo test.
  static constexpr double kArmijo = 1e-4;
  // Halvings along the projection arc and along the scaled gradient.
  static constexpr int kArcHalvings = 40;
  static constexpr int kGradientHalvings = 60;
  // The tolerance is never below this many eps sqrt(m + 1): the rounding
  // level of the gradient itself.
  static constexpr double kRoundingFactor = 32.0;
  // Iterative refinements of a solve with K.
  static constexpr int kRefinements = 4;
};

// Mehrotra predictor-corrector interior-point phase.
struct InteriorPointConstants {
  static constexpr int kMaxIterations = 60;
  // Stop when the dual residual is below this fraction of the scale and the
  // mean complementarity below this fraction of the scale squared: the
  // crossover needs every active bound's slack under its multiplier, and
  // the multipliers of near-mechanisms under gravity are tiny.
  static constexpr double kDualTolerance = 1e-10;
  static constexpr double kComplementarityTolerance = 1e-20;
  static constexpr double kFractionToBoundary = 0.995;
  static constexpr double kCenteringPower = 3.0;  // Mehrotra's sigma = (gap_aff / gap)^3
  static constexpr double kSmallestMultiplier = 1e-300;
  static constexpr int kRefinements = 3;
  // The early end of the phase (StressQpOptions::end_interior_point_when_settled):
  // the window of iterations, the largest relative change of the relative
  // residual over it, the least fall of the mean complementarity across it,
  // and how far above give_up_residual the residual must have settled.
  static constexpr int kSettledWindow = 2;
  static constexpr double kSettledChange = 0.01;
  static constexpr double kSettledGapFall = 4.0;
  static constexpr double kSettledAboveGiveUp = 10.0;
};

// Polish: preconditioned conjugate gradients on the free set.
struct PolishConstants {
  // Conjugate-gradient iterations per polish step: the preconditioner
  // (N + mu I)_FF leaves only the few eigenvalues below mu to resolve.
  static constexpr int kMaxCgIterations = 200;
  // CG stops when its residual is below this many eps times the gradient scale.
  static constexpr double kCgRoundingFactor = 4.0;
  // A polish step that lowers the objective by less than this fraction ends the polish.
  static constexpr double kSlowProgress = 0.01;
};

// The certificate of an optimum (StressQpOptions::certify_optimum).
struct CertificateConstants {
  // Optimal needs the lower bound at least this fraction of the objective:
  // the optimum's residual is then at least half the returned one.
  static constexpr double kCertifiedFraction = 0.25;
};

struct Impl;

// The state of one solve: inputs fixed for the solve, the running flags of
// the phases, and the counters reported in StressQpResult.
struct SolveState {
  const SparseMatrix* A = nullptr;
  const Eigen::VectorXd* fg = nullptr;  // gravity load, or null
  double fg_max = 0.0;
  double tolerance = 0.0;  // relative projected-gradient tolerance
  bool warm_start = false;
  bool ok = true;              // no numerical failure so far
  bool settled = false;        // the active set has settled (projected Newton converged)
  bool interior_point_used = false;
  bool stuck = false;          // projected Newton cannot progress
  bool hit_iteration_cap = false;  // stopped at StressQpOptions::max_iterations
  bool gave_up = false;            // stopped at StressQpOptions::give_up_after (not a step cap)
  bool last_step_exact = false;
  int nonmonotone_left = 0;
  double best_objective = kInf;
  int iterations = 0, factorizations = 0, polish_steps = 0;
};

struct Impl {
  // Problem data.
  int m = 0;      // elements (unknowns)
  int rows = 0;   // 3 n_free (equations)
  double mu = 0.0, w2 = 0.0, target = 0.0, f0 = 1.0;
  double scale_target = 0.0;  // t of the ForceScale; target = t + the shift's
  bool normalised = false;
  Eigen::VectorXd lower, upper, c;
  // StressQp::set_shift: a load added to f_g (empty: none) and f_g + it.
  Eigen::VectorXd load_shift, shifted_load;
  double target_shift = 0.0;

  // A's pattern as analysed (column starts, row indices, value offsets), to
  // detect a topology change and to address A's values directly.
  std::vector<int> a_col_start, a_row, a_value;

  // K (lower triangle, (m+1) x (m+1)), its values for an empty held set, and
  // for every value of K the pairs of A values whose products sum into it.
  SparseMatrix K;
  std::vector<double> base;
  std::vector<int> k_row, k_col;
  std::vector<int> pair_start, pair_a, pair_b;
  Eigen::VectorXd diag_n;  // N_ii = |A_i|^2 + w^2 c_i^2 + mu

  PatternLdlt ldlt;  // K's pattern analysed once per topology

  // StressQpOptions::node_space: K is never formed; M = I + B D^{-1} B^T is
  // factorized instead (NormalMatrix with J = I, weights 1/D_e).
  bool node_space = false;
  const SparseMatrix* node_a = nullptr;  // A of the current solve (refresh)
  std::unique_ptr<NormalMatrix> node_matrix;
  SparseMatrix node_identity;            // 3x3 identity blocks: M's I
  Eigen::VectorXd node_weight;           // 1/D_e on free forces, 0 on held ones
  Eigen::VectorXd held_inverse;          // 1/N_ii on held forces, 0 on free ones
  Eigen::VectorXd node_rhs, node_sol;    // B D^{-1} b and M^{-1} of it (rows (+1))
  Eigen::VectorXd node_back;             // B^T M^{-1} B D^{-1} b (m)
  bool factorization_valid = false;
  std::vector<char> held, factored_held;  // W of the current step / of the factorization

  // Work space, sized once per topology.
  Eigen::VectorXd center;
  Eigen::VectorXd ip_h, ip_rd, ip_zl, ip_zu, ip_d, ip_rhs, ip_dx, ip_dx_aff, ip_dzl, ip_dzu;
  Eigen::VectorXd s, g, d, trial, step, rhs, lin_res, op_out, masked, best_s;
  Eigen::VectorXd cg_x, cg_r, cg_z, cg_p, cg_q;
  Eigen::VectorXd aug_rhs, aug_sol;
  Eigen::VectorXd correction;  // a refinement's correction (m)
  Eigen::VectorXd r, a_step;  // equation-sized

  // Set-up and linear algebra (stress_qp.cpp).
  void build(const SparseMatrix& A, const ForceScale& scale, const StressQpOptions& o);
  bool pattern_matches(const SparseMatrix& A) const;
  bool refresh(const SparseMatrix& A);
  bool factorize(const std::vector<char>& hold);
  bool factorize_with_diagonal(const Eigen::VectorXd& extra);
  bool solve_with_diagonal(const SparseMatrix& A, const Eigen::VectorXd& extra, const Eigen::VectorXd& b,
                           Eigen::VectorXd& x);
  void apply_normal(const SparseMatrix& A, const Eigen::VectorXd& x, Eigen::VectorXd& out);
  void apply_modified(const Eigen::VectorXd& x, const SparseMatrix& A, Eigen::VectorXd& out);
  bool solve_modified(const SparseMatrix& A, const Eigen::VectorXd& b, Eigen::VectorXd& x);
  // x = K^{-1} [b; 0] without refinement (a fixed linear operator: CG's preconditioner).
  void apply_preconditioner(const Eigen::VectorXd& b, Eigen::VectorXd& x);
  void build_force_space();
  // Node-space set-up, values and factorization (StressQpOptions::node_space).
  void build_node_space(const SparseMatrix& A);
  void refresh_node_space(const SparseMatrix& A);
  bool factorize_node_space();
  // x = M-based K^{-1} [b; 0], first m entries (Woodbury).
  void apply_node_space_inverse(const Eigen::VectorXd& b, Eigen::VectorXd& x);
  template <class Apply>
  bool refined_solve(const Eigen::VectorXd& b, Eigen::VectorXd& x, int refinements, Apply apply);
  void residual(const SparseMatrix& A, const Eigen::VectorXd* fg, const Eigen::VectorXd& x,
                Eigen::VectorXd& res) const;
  double project(int i, double v) const { return std::min(std::max(v, lower[i]), upper[i]); }
  // |A dx|^2 + w^2 (c.dx)^2: the mu-free objective's curvature along dx
  // (leaves A dx in a_step).
  double curvature(const SparseMatrix& A, const Eigen::VectorXd& dx) {
    a_step.noalias() = A * dx;
    const double c_dx = c.dot(dx);
    return a_step.squaredNorm() + w2 * c_dx * c_dx;
  }
  // r = A x + f_g and g = A^T r + w^2 c (c^T x - t) + mu_term (x - centre).
  void evaluate(const SolveState& st, const Eigen::VectorXd& x, double mu_term);
  // Half the regularised objective at x; leaves r and g evaluated there.
  double regularised_objective(const SolveState& st, const Eigen::VectorXd& x);
  // |A x + f_g|^2 + w^2 (c^T x - t)^2 (no mu term, not halved); leaves r and
  // the mu-free g evaluated there.
  double mu_free_objective(const SolveState& st, const Eigen::VectorXd& x);
  // The scale of gradients and forces that the tolerances are relative to.
  double gradient_scale(const SolveState& st, const Eigen::VectorXd& x) const;
  // Max over free nodes of |v_i| for a vector of 3 entries per free node.
  double largest_node_norm(const Eigen::VectorXd& v) const;
  // At forces x (r evaluated there): the largest free-node residual over the
  // largest free-node load (model/verify's measure), or over |x|_inf without loads.
  double relative_residual(const SolveState& st, const Eigen::VectorXd& x) const;

  // Phases.
  // Projected Newton with an active set, from s (stress_qp_projected_newton.cpp).
  void projected_newton(const StressQpOptions& options, SolveState& st);
  // One Newton step of projected Newton; false when no progress is possible.
  bool projected_newton_step(SolveState& st, bool record);
  // Interior point + crossover (stress_qp_interior_point.cpp); returns the
  // number of factorizations. `give_up_residual` > 0: ends early where
  // StressQpOptions::end_interior_point_when_settled says.
  int interior_point(const SolveState& st, const Eigen::VectorXd& centre, double scale, double give_up_residual,
                     Eigen::VectorXd& x);
  // Removes the mu bias on the free set (stress_qp_polish.cpp).
  void polish(const StressQpOptions& options, SolveState& st);
  void polish_free_set(const StressQpOptions& options, SolveState& st);
  void polish_to_optimum(const StressQpOptions& options, SolveState& st);
  // A lower bound on the mu-free objective over the whole box, or -infinity
  // when none is found (stress_qp_polish.cpp). Leaves s unchanged.
  double objective_lower_bound(SolveState& st);
};

}  // namespace stress_qp_detail
}  // namespace tensegrity
