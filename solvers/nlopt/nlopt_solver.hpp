#pragma once
// The `nlopt` backend: Eq. 5 (formulations/minimal_geometry_change_nlp.hpp)
// solved with NLopt's local gradient algorithms, in one of two formulations.
//
// formulation=varpro (reduced_residual.hpp): variable projection. The
// stress QP (Eq. 4) gives the forces for given positions, R(q) is its optimal
// residual (relative to F0) with its gradient from the envelope theorem, and
// NLopt works on the positions alone, in one of two ways:
//  - the method of multipliers on the residual vector (nlopt_varpro_multipliers.cpp):
//    min_q |q - q0|^2 / L^2 + (rho / 2) min_sigma |r + lambda / rho|^2 with
//    NLopt's L-BFGS or truncated Newton, then lambda += rho r;
//  - one scalar constraint (nlopt_varpro.cpp): min |q - q0|^2 / L^2 subject
//    to sqrt(R(q)) <= tau.
//   varpro_algorithm  auto (default: al-lbfgs with half the budget, then where
//                     it ends unverified slsqp up to kLargestDenseSlsqpVariables
//                     position variables, ccsaq above), al-lbfgs, al-tnewton
//                     (the multiplier method), slsqp (NLopt's SLSQP, dense),
//                     ccsaq, mma (the CCSA methods), auglag-lbfgs (NLopt's
//                     AUGLAG around LD_LBFGS)
//   varpro_penalty_initial  rho at the start of the multiplier method (100)
//   varpro_rounds     scalar route: NLopt runs at most, each with tau ten times
//                     smaller when the verification rejected the previous one (4)
//
// formulation=full (nlopt_full*.cpp): NLopt has no sparse linear algebra, and
// its constrained algorithms either need a dense Jacobian of full row rank
// (SLSQP; tensegrity equilibrium matrices are often rank-deficient) or handle
// only inequalities (MMA, CCSAQ), so `algorithm` al-* wraps NLopt's
// bound-constrained algorithms in an augmented-Lagrangian outer loop of our own:
//
//   y = (q / L, sigma / F0)                      (dimensionless variables)
//   c(y) = (f(q, sigma) / F0, c^T sigma / (n_c F0) - 1)
//   min_y  |q - q0|^2 / L^2 + lambda^T c(y) + (rho / 2) |c(y)|^2
//   s.t.   sigma within the ForceScale sign bounds (NLopt box bounds)
//
// after each inner solve lambda += rho c and rho grows tenfold when |c| did not
// shrink fourfold. Stops once the relative residual (docs/FORMATS.md) is below half
// the tolerance.
//   algorithm       al-lbfgs (default), al-tnewton, al-mma, al-ccsaq (the same
//                   outer loop around another NLopt bound-constrained local
//                   algorithm), penalty-lbfgs (quadratic penalty continuation,
//                   no multipliers), auglag-eq-lbfgs (NLopt's own AUGLAG_EQ
//                   around LD_LBFGS), slsqp (NLopt's SLSQP on Eq. 5, dense)
//   penalty_initial rho at the start (10), penalty_growth (10), penalty_max (1e12)
//   init            qp (stress QP at the scene geometry, default) or reference
//                   (+F0 on cables, -F0 on struts)
// max_iterations bounds the outer iterations (every NLopt algorithm's own
// iterations are bounded by maxeval).
//
// Both formulations:
//   ftol_rel, xtol_rel   NLopt stopping tolerances of each NLopt run (1e-15)
//   maxeval         total function evaluations; default: the iteration budget
//                   (SolveOptions::iteration_budget: 2000 when max_iterations is
//                   0) for varpro, where an evaluation is one stress-QP solve and
//                   counts as an iteration, 100 times that for full
//   lbfgs_memory    L-BFGS / TNEWTON vector storage, 0 = NLopt's heuristic (0)
// time_limit_s becomes NLopt's maxtime. Every result is re-verified by
// model/verify before it is called converged.
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "solvers/solver.hpp"

namespace tensegrity {

// Largest L-BFGS / TNEWTON vector storage an option may ask for.
inline constexpr int kLargestLbfgsMemory = 1000;

// varpro_algorithm=auto falls back to SLSQP up to this many position
// variables: beyond it one SLSQP iteration (dense, cubic in the variables) can
// outlast a time limit, which NLopt checks only between evaluations.
inline constexpr int kLargestDenseSlsqpVariables = 600;

// Most NLopt runs of formulation=varpro an option may ask for.
inline constexpr int kLargestVarproRounds = 100;

struct NloptOptions {
  std::string formulation = "varpro";  // varpro | full
  std::string varpro_algorithm = "auto";  // see above
  int varpro_rounds = 4;
  std::string algorithm = "al-lbfgs";  // formulation=full, see above
  double ftol_rel = 1e-15;             // NLopt stopping tolerances of each NLopt run
  double xtol_rel = 1e-15;
  long maxeval = 0;                    // total evaluations; 0: 100 x the iteration budget
  double penalty_initial = 10.0;       // rho at the start (formulation=full)
  double varpro_penalty_initial = 100.0;  // rho at the start (varpro al-lbfgs, al-tnewton)
  double penalty_growth = 10.0;        // factor when |c| did not shrink fourfold
  double penalty_max = 1e12;
  int lbfgs_memory = 0;                // 0: NLopt's heuristic
  std::string init = "qp";             // qp | reference
  static NloptOptions FromPairs(const OptionPairs& pairs);
  bool IsValid(std::string* why = nullptr) const;
};

class NloptSolver : public SolverWithOptions<NloptOptions> {
 public:
  std::string_view name() const override { return "nlopt"; }
  // formulation=full's algorithms and formulation=varpro's.
  static std::vector<std::string> algorithm_names();
  static std::vector<std::string> varpro_algorithm_names();
  static std::string default_algorithm() { return "al-lbfgs"; }

 protected:
  SolveResult DoSolve(const PartProblem& problem, const NloptOptions& options) const override;
};

std::unique_ptr<Solver> make_nlopt_solver();

}  // namespace tensegrity
