#include "solvers/eq5_newton/interior_newton.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <Eigen/OrderingMethods>

#include "kernels/node_block_ldlt.hpp"

namespace tensegrity {
namespace {

// A start force closer to its bound than this share of the (scaled) margin is
// moved to it: a slack of zero has no barrier, a tiny one an enormous multiplier.
constexpr double kStartSlackShare = 1e-2;
constexpr double kSmallestStartSlack = 1e-12;
// Barrier update (Ipopt's monotone rule): solve each barrier problem to
// kBarrierTolerance * mu, then mu <- max(mu_min, min(kBarrierDecrease mu, mu^kBarrierExponent)).
constexpr double kBarrierTolerance = 10.0;
constexpr double kBarrierDecrease = 0.2;
constexpr double kBarrierExponent = 1.5;
// Fraction to the boundary: a step keeps at least (1 - tau) of every slack, tau >= this.
constexpr double kSmallestFractionToBoundary = 0.99;
// Bound multipliers are kept within [mu / (k d), k mu / d] (Ipopt's kappa_Sigma).
constexpr double kMultiplierSafeguard = 1e10;
// Filter line search (Waechter and Biegler 2006, Ipopt's constants): the
// Armijo constant, the margins a trial must gain on the filter's entries, the
// exponents of the switching rule, and theta_max / theta_min relative to the
// start's infeasibility; the largest number of halvings and the smallest step.
constexpr double kArmijo = 1e-4;
constexpr double kFilterInfeasibilityMargin = 1e-5;
constexpr double kFilterObjectiveMargin = 1e-8;
constexpr double kSwitchingObjectiveExponent = 2.3;
constexpr double kSwitchingInfeasibilityExponent = 1.1;
constexpr double kLargestInfeasibility = 1e4;
constexpr double kSmallInfeasibility = 1e-4;
constexpr int kMaxBacktracks = 40;
constexpr double kSmallestStep = 1e-14;
// Progress filter (Ipopt's adaptive mu globalization, obj-constr-filter): a
// point makes progress when, against every earlier point of Mehrotra's rule,
// it is lower in |c|_1 or in phi by this margin times min(1, |c|_1); where it
// does not, the monotone rule starts from this share of the mean
// complementarity (Ipopt's adaptive_mu_monotone_init_factor).
constexpr double kProgressMargin = 1e-5;
constexpr double kMonotoneStartShare = 0.8;
// delta_c on the multipliers' diagonal (quasi-definite matrix).
constexpr double kDualRegularisation = 1e-10;
// Inertia correction (Ipopt's rule): the first delta_w, its growth on the first
// and on later failures, its reduction from the last successful one, its bounds.
constexpr double kFirstShift = 1e-4;
constexpr double kFirstShiftGrowth = 100.0;
constexpr double kShiftGrowth = 8.0;
constexpr double kShiftReduction = 1.0 / 3.0;
constexpr double kSmallestShift = 1e-20;
constexpr double kLargestShift = 1e20;
// After this many consecutive shifted steps a third of the previous shift is
// tried first, while it stays above kRetryUnshiftedBelow; below it the
// unshifted matrix is tried first again.
constexpr int kIndefiniteStretch = 2;
constexpr double kRetryUnshiftedBelow = 1e-8;
// Stationary stop (interior_newton.hpp): the window of iterations, the
// largest relative objective change over it, the largest KKT residual, the
// least share of the KKT error the window must have kept (so that a run
// converging fast is never stopped), and how close mu must be to its floor;
// then at most this many projection steps.
constexpr int kStationaryWindow = 10;
constexpr double kStationaryObjectiveChange = 1e-5;
constexpr double kStationaryKktError = 1e-5;
constexpr double kStationaryKktShare = 0.1;
constexpr double kStationaryBarrierFactor = 2.0;
constexpr int kProjectionSteps = 6;
// When those steps leave the bounds (multipliers v of a polish far from its
// optimum do not hold the forces near their bounds), the projection is
// repeated in the metric I + Sigma + w / d^2, the Hessian of a log barrier of
// weight w added, with steps cut to the fraction to the boundary; it then
// gains about a factor of two per step, hence the larger number of steps.
constexpr double kSafeguardBarrierWeight = 1e-6;
constexpr int kSafeguardedProjectionSteps = 40;
// Iterative refinement of each solve against the matrix without delta_c: at
// most this many steps, until the residual is below the tolerance relative to
// |b|, or until a step no longer halves it (it has reached its rounding floor,
// where further steps only add rounding).
constexpr int kRefinementSteps = 6;
constexpr double kRefinementTolerance = 1e-14;
constexpr double kRefinementProgress = 0.5;

// The KKT matrix's groups for NodeBlockLdlt, in an elimination order with as
// little fill as AMD's on the whole matrix but found on the much smaller node
// graph (0.1 ms on the 80/500 tower): the forces (and the cap's slack) first,
// each coupling only the nodes it joins; then per free node its three
// positions and its three equilibrium multipliers as one block, the nodes in
// AMD's order on the node graph; the cable-sum row last (once the forces are
// eliminated it couples every node).
// Variables: nq positions (x, y, z per free node), then the forces and the
// slack, up to n; then the multipliers, the first nq per free node in the
// positions' node order. `jacobian`: the constraint Jacobian's pattern.
struct KktGroups {
  std::vector<int> scalars, tail;
  std::vector<NodeBlockLdlt::Block> blocks;
};

KktGroups structured_kkt_groups(const Eigen::SparseMatrix<double>& jacobian, int n, int nq, int size) {
  const int nodes = nq / 3;
  // Node graph: nodes a and b are adjacent when block (a, b) of df/dq is
  // present, i.e. when an element joins them; one entry per 3x3 block.
  std::vector<Eigen::Triplet<double>> edges;
  for (int a = 0; a < nodes; ++a) {
    edges.emplace_back(a, a, 1.0);
    for (Eigen::SparseMatrix<double>::InnerIterator it(jacobian, 3 * a); it; ++it)
      if (it.row() < nq && it.row() % 3 == 0) edges.emplace_back(static_cast<int>(it.row()) / 3, a, 1.0);
  }
  Eigen::SparseMatrix<double> graph(nodes, nodes);
  graph.setFromTriplets(edges.begin(), edges.end());
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> node_order;
  Eigen::AMDOrdering<int>()(graph, node_order);

  KktGroups groups;
  for (int v = nq; v < n; ++v) groups.scalars.push_back(v);
  for (int i = 0; i < nodes; ++i) {
    const int a = node_order.indices()[i];
    groups.blocks.push_back({3 * a, 3 * a + 1, 3 * a + 2, n + 3 * a, n + 3 * a + 1, n + 3 * a + 2});
  }
  for (int v = n + nq; v < size; ++v) groups.tail.push_back(v);
  return groups;
}

// The KKT matrix [W, J^T; J, -delta_c I] (lower triangle), its pattern and
// elimination order analysed once, values rewritten every factorization.
class KktSystem {
 public:
  // `refine`: iterative refinement against the matrix without delta_c
  // after each solve; without it the solutions keep delta_c.
  KktSystem(const Eigen::SparseMatrix<double>& hessian_pattern, const Eigen::SparseMatrix<double>& jacobian_pattern,
            int num_positions, bool refine)
      : n_(static_cast<int>(hessian_pattern.rows())),
        mc_(static_cast<int>(jacobian_pattern.rows())),
        nq_(num_positions),
        refine_(refine) {
    std::vector<int> rows, cols;
    for (int j = 0; j < hessian_pattern.outerSize(); ++j)
      for (Eigen::SparseMatrix<double>::InnerIterator it(hessian_pattern, j); it; ++it)
        rows.push_back(static_cast<int>(it.row())), cols.push_back(j);
    const int nh = static_cast<int>(rows.size());
    for (int j = 0; j < jacobian_pattern.outerSize(); ++j)
      for (Eigen::SparseMatrix<double>::InnerIterator it(jacobian_pattern, j); it; ++it)
        rows.push_back(n_ + static_cast<int>(it.row())), cols.push_back(j);
    const int nj = static_cast<int>(rows.size()) - nh;
    for (int i = 0; i < n_ + mc_; ++i) rows.push_back(i), cols.push_back(i);
    std::vector<int> slot;
    matrix_ = sparse_pattern(n_ + mc_, n_ + mc_, rows, cols, 0, slot);
    hessian_slot_.assign(slot.begin(), slot.begin() + nh);
    jacobian_slot_.assign(slot.begin() + nh, slot.begin() + nh + nj);
    diagonal_slot_.assign(slot.begin() + nh + nj, slot.end());
    const KktGroups groups = structured_kkt_groups(jacobian_pattern, n_, nq_, n_ + mc_);
    ldlt_.analyze(matrix_, groups.scalars, groups.blocks, groups.tail);
  }

  // Writes and factorizes the matrix; true when it factorized with inertia
  // (n positive, mc negative pivots).
  bool factorize(const Eigen::SparseMatrix<double>& H, const Eigen::SparseMatrix<double>& J,
                 const Eigen::VectorXd& force_diagonal, double delta_w) {
    double* values = matrix_.valuePtr();
    std::fill(values, values + matrix_.nonZeros(), 0.0);
    const double* h = H.valuePtr();
    for (std::size_t k = 0; k < hessian_slot_.size(); ++k) values[hessian_slot_[k]] += h[k];
    const double* a = J.valuePtr();
    for (std::size_t k = 0; k < jacobian_slot_.size(); ++k) values[jacobian_slot_[k]] += a[k];
    for (int i = 0; i < n_; ++i) values[diagonal_slot_[i]] += delta_w;
    for (int e = 0; e < n_ - nq_; ++e) values[diagonal_slot_[nq_ + e]] += force_diagonal[e];
    for (int i = 0; i < mc_; ++i) values[diagonal_slot_[n_ + i]] -= kDualRegularisation;
    if (!ldlt_.factorize(values)) return false;
    return ldlt_.positive_pivots() == n_ && ldlt_.negative_pivots() == mc_;
  }

  // Solves [W, J^T; J, 0] x = b with the factorization of the delta_c matrix
  // and iterative refinement (without it, [W, J^T; J, -delta_c I] x = b).
  void solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
    ldlt_.solve(b, x);
    if (!refine_) return;
    const double scale = std::max(1.0, b.cwiseAbs().maxCoeff());
    double last_norm = std::numeric_limits<double>::infinity();
    for (int step = 0; step < kRefinementSteps; ++step) {
      residual_ = b - matrix_.selfadjointView<Eigen::Lower>() * x;
      residual_.tail(mc_) -= kDualRegularisation * x.tail(mc_);
      const double norm = residual_.cwiseAbs().maxCoeff();
      if (norm <= kRefinementTolerance * scale || norm > kRefinementProgress * last_norm) break;
      last_norm = norm;
      ldlt_.solve(residual_, correction_);
      x += correction_;
    }
  }

 private:
  int n_, mc_, nq_;
  bool refine_;
  Eigen::SparseMatrix<double> matrix_;
  std::vector<int> hessian_slot_, jacobian_slot_, diagonal_slot_;
  NodeBlockLdlt ldlt_;  // the symbolic work done once
  Eigen::VectorXd residual_, correction_;
};

// Values of the merit function's pieces at one point.
struct MeritPoint {
  double objective = 0.0;           // phi
  double barrier = 0.0;             // - sum log d
  double infeasibility = 0.0;       // |c|_1
  Eigen::VectorXd c, d;
  bool inside = false;              // every slack positive
};

void evaluate(ScaledEq5& problem, const Eigen::VectorXd& y, MeritPoint& p) {
  problem.slacks(y, p.d);
  p.inside = (p.d.array() > 0.0).all();
  if (!p.inside) return;
  p.objective = problem.objective(y);
  problem.constraints(y, p.c);
  p.infeasibility = p.c.lpNorm<1>();
  p.barrier = -p.d.array().log().sum();
}

// Whether c meets the stop's test: every node row within `tolerance`, the
// cable-sum row within the larger of it and the row's rounding floor
// (scaled_eq5.hpp), which on large structures lies above it while the node
// rows are met long before.
bool constraints_met(const ScaledEq5& problem, const Eigen::VectorXd& y, const Eigen::VectorXd& c,
                     double tolerance) {
  const int row = problem.has_cable_sum_row() ? problem.num_positions() : -1;
  for (int i = 0; i < c.size(); ++i)
    if (i != row && !(std::abs(c[i]) <= tolerance)) return false;
  return row < 0 || std::abs(c[row]) <= std::max(tolerance, problem.cable_sum_row_floor(y));
}

// Moves y towards c(y) = 0 by minimal-norm Newton steps in the metric
// I + Sigma + w / d^2 (Sigma = v / d on the bounded variables, so that those
// at their bounds stay put; w = 0 or kSafeguardBarrierWeight):
// [I + metric, J^T; J, -delta_c I] (dy, lambda) = (0, -c), until |c|_inf is
// below `tolerance` or stops falling (its round-off floor). Without w a step
// that leaves the bounds fails the projection; with it each step is cut to
// the fraction to the boundary. False when a step fails or is not finite.
// `no_curvature`: the Hessian's pattern with zero values.
bool project_with_metric(ScaledEq5& problem, KktSystem& kkt, const Eigen::SparseMatrix<double>& no_curvature,
                         const Eigen::VectorXd& v, double tolerance, double barrier_weight, int max_steps,
                         Eigen::VectorXd& y, MeritPoint& here) {
  const int n = problem.num_variables(), mc = problem.num_constraints(), nq = problem.num_positions();
  const int m = problem.num_bounded();
  const Eigen::VectorXd& S = problem.bound_signs();
  const bool safeguarded = barrier_weight > 0.0;
  constexpr double kUnitMetric = 1.0;
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n + mc), step, y_next, metric;
  MeritPoint next;
  for (int k = 0; k < max_steps && here.c.cwiseAbs().maxCoeff() > tolerance; ++k) {
    metric = v.cwiseQuotient(here.d);
    if (safeguarded) metric.array() += barrier_weight / here.d.array().square();
    if (!kkt.factorize(no_curvature, problem.jacobian(y), metric, kUnitMetric)) return false;
    rhs.tail(mc) = -here.c;
    kkt.solve(rhs, step);
    if (!step.allFinite()) return false;
    double alpha = 1.0;
    if (safeguarded)
      for (int e = 0; e < m; ++e) {
        const double dd = S[e] * step[nq + e];
        if (dd < 0.0) alpha = std::min(alpha, -kSmallestFractionToBoundary * here.d[e] / dd);
      }
    y_next = y + alpha * step.head(n);
    evaluate(problem, y_next, next);
    if (!next.inside) return false;
    if (next.c.cwiseAbs().maxCoeff() >= here.c.cwiseAbs().maxCoeff()) break;
    y.swap(y_next);
    std::swap(here, next);
  }
  return true;
}

// The projection in the plain metric, and where it fails the safeguarded one
// from the point it reached.
bool project_onto_constraints(ScaledEq5& problem, KktSystem& kkt, const Eigen::VectorXd& lambda,
                              const Eigen::VectorXd& v, double tolerance, Eigen::VectorXd& y, MeritPoint& here) {
  Eigen::SparseMatrix<double> no_curvature = problem.hessian(y, lambda);
  no_curvature.coeffs().setZero();
  constexpr double kPlainMetric = 0.0;
  if (project_with_metric(problem, kkt, no_curvature, v, tolerance, kPlainMetric, kProjectionSteps, y, here))
    return true;
  return project_with_metric(problem, kkt, no_curvature, v, tolerance, kSafeguardBarrierWeight,
                             kSafeguardedProjectionSteps, y, here);
}

}  // namespace

InteriorNewtonOutcome solve_interior_newton(ScaledEq5& problem, const Eigen::VectorXd& y0,
                                            const InteriorNewtonSettings& settings,
                                            const InteriorNewtonObserver& observer) {
  const auto start = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  const int n = problem.num_variables(), mc = problem.num_constraints(), nq = problem.num_positions();
  const int m = problem.num_bounded();  // the bounded tail of y: the forces, then the cap's slack
  const Eigen::VectorXd& S = problem.bound_signs();
  const Eigen::VectorXd& margins = problem.bound_margins();
  InteriorNewtonOutcome out;

  // The start, with every force strictly inside its bound.
  Eigen::VectorXd y = y0;
  const double min_slack = std::max(kSmallestStartSlack, kStartSlackShare * problem.scaled_margin());
  for (int e = 0; e < m; ++e) {
    const double d = S[e] * y[nq + e] - margins[e];
    if (!(d >= min_slack)) y[nq + e] = S[e] * (margins[e] + min_slack);
  }
  const double mu_min = settings.optimality_tolerance / (kBarrierTolerance + 1.0);
  double mu = std::max(settings.initial_barrier, mu_min);

  MeritPoint here, trial, corrected;
  evaluate(problem, y, here);
  Eigen::VectorXd lambda = Eigen::VectorXd::Zero(mc);
  Eigen::VectorXd v = mu * here.d.cwiseInverse();
  Eigen::VectorXd g, rd, rhs(n + mc), solution, dy, dv, lambda_plus, sigma_diag, rhs_soc(n + mc), soc, y_trial, y_soc, corrector,
      ds_affine(m), dv_affine(m);  // sized once: the loop assigns into them
  problem.gradient(y, g);
  const Eigen::SparseMatrix<double>* J = &problem.jacobian(y);
  KktSystem kkt(problem.hessian(y, lambda), *J, nq, !settings.regularised_steps);
  double last_shift = 0.0;      // the last shift an inertia correction found
  double previous_shift = 0.0;  // the shift of the previous iteration's step
  int shifted_steps = 0;        // consecutive steps taken with a shift
  const double theta_max = kLargestInfeasibility * std::max(1.0, here.infeasibility);
  const double theta_min = kSmallInfeasibility * std::max(1.0, here.infeasibility);
  std::vector<std::pair<double, double>> filter;  // (theta, phi_mu) pairs a trial must not be dominated by
  double filter_mu = mu;
  bool free_mode = settings.predictor_corrector;
  std::vector<std::pair<double, double>> progress_filter;  // (theta, phi) of earlier points of Mehrotra's rule
  // phi and the KKT error at every point reached, for the stationary stop.
  std::vector<double> objective_history, kkt_history;
  objective_history.reserve(static_cast<std::size_t>(std::max(0, settings.max_iterations)) + 1);
  kkt_history.reserve(objective_history.capacity());
  if (settings.progress_filter) progress_filter.reserve(objective_history.capacity());
  objective_history.push_back(here.objective);
  out.y = y;
  out.lambda = lambda;
  out.bound_multipliers = v;

  // The last iterate of a polish that ends without an answer (a stalled line
  // search, the budget spent) may already be much closer to the scene than
  // the start: projected onto the constraints it can still be one.
  auto project_last_iterate = [&](int iteration) {
    out.last_iterate_projected =
        project_onto_constraints(problem, kkt, lambda, v, settings.constraint_tolerance, y, here);
    if (!out.last_iterate_projected) return;
    out.y = y;
    out.constraint_violation = here.c.cwiseAbs().maxCoeff();
    if (observer) observer(iteration + 1, y);
  };

  for (int iteration = 0;; ++iteration) {
    // Optimality of the current point.
    rd = g + J->transpose() * lambda;
    rd.tail(m) -= S.cwiseProduct(v);
    out.dual_infeasibility = rd.cwiseAbs().maxCoeff();
    out.constraint_violation = here.c.cwiseAbs().maxCoeff();
    out.complementarity = here.d.cwiseProduct(v).cwiseAbs().maxCoeff();
    out.iterations = iteration;
    out.y = y;
    out.lambda = lambda;
    out.bound_multipliers = v;
    if (out.dual_infeasibility <= settings.optimality_tolerance &&
        out.complementarity <= settings.optimality_tolerance &&
        constraints_met(problem, y, here.c, settings.constraint_tolerance)) {
      out.status = Status::Converged;
      out.message = "KKT conditions of Eq. 5 met";
      return out;
    }
    auto makes_progress = [&] {
      const double margin = kProgressMargin * std::min(1.0, here.infeasibility);
      for (const auto& [theta_f, phi_f] : progress_filter)
        if (!(here.infeasibility + margin < theta_f || here.objective + margin < phi_f)) return false;
      return true;
    };
    auto remember_progress = [&] { progress_filter.emplace_back(here.infeasibility, here.objective); };
    auto barrier_error = [&] {
      const double comp = (here.d.cwiseProduct(v).array() - mu).abs().maxCoeff();
      return std::max({out.dual_infeasibility, out.constraint_violation, comp});
    };
    // Mehrotra's rule while every point makes progress against the
    // progress filter; otherwise the monotone rule until a barrier problem
    // is solved at a point that does.
    if (free_mode && settings.progress_filter) {
      if (makes_progress()) {
        remember_progress();
      } else {
        free_mode = false;
        mu = std::max(mu_min, kMonotoneStartShare * here.d.dot(v) / std::max(1, m));
      }
    }
    if (!free_mode) {
      const bool solved = barrier_error() <= kBarrierTolerance * mu;
      if (settings.predictor_corrector && solved && makes_progress()) {
        free_mode = true;
        remember_progress();
      } else {
        while (mu > mu_min && barrier_error() <= kBarrierTolerance * mu)
          mu = std::max(mu_min, std::min(kBarrierDecrease * mu, std::pow(mu, kBarrierExponent)));
      }
    }
    const double kkt_error = std::max({out.dual_infeasibility, out.constraint_violation, out.complementarity});
    kkt_history.push_back(kkt_error);
    auto objective_stationary = [&] {
      const std::size_t points = objective_history.size();
      if (!settings.stationary_stop || points <= kStationaryWindow) return false;
      const std::size_t then = points - 1 - kStationaryWindow;
      return mu <= kStationaryBarrierFactor * mu_min && kkt_error <= kStationaryKktError &&
             kkt_error >= kStationaryKktShare * kkt_history[then] &&
             std::abs(objective_history[then] - here.objective) <= kStationaryObjectiveChange * std::abs(here.objective);
    };
    if (objective_stationary()) {
      out.status = Status::Stalled;
      out.message = "the objective stopped changing before the KKT test passed";
      out.stationary_projected =
          project_onto_constraints(problem, kkt, lambda, v, settings.constraint_tolerance, y, here);
      if (out.stationary_projected) {
        out.y = y;
        out.constraint_violation = here.c.cwiseAbs().maxCoeff();
        if (observer) observer(iteration + 1, y);
      }
      return out;
    }
    if (iteration >= settings.max_iterations) {
      out.status = Status::MaxIterations;
      out.message = "Newton iteration budget spent";
      project_last_iterate(iteration);
      return out;
    }
    if (seconds() > settings.time_limit_s) {
      out.status = Status::TimeLimit;
      out.message = "time limit";
      return out;
    }

    // Newton step with inertia correction.
    const Eigen::SparseMatrix<double>& H = problem.hessian(y, lambda);
    sigma_diag = v.cwiseQuotient(here.d).array() + settings.proximal_weight;
    // In an indefinite stretch (the last steps all needed a shift) first try
    // a third of the previous shift rather than none: there the unshifted
    // matrix fails again and again, and each failure costs a factorization.
    const bool indefinite_stretch = shifted_steps >= kIndefiniteStretch && previous_shift > kRetryUnshiftedBelow;
    double shift = indefinite_stretch ? kShiftReduction * previous_shift : 0.0;
    ++out.factorizations;
    bool ok = kkt.factorize(H, *J, sigma_diag, shift);
    if (!ok) {
      if (shift > 0.0)
        shift *= kShiftGrowth;
      else
        shift = last_shift == 0.0 ? kFirstShift : std::max(kSmallestShift, kShiftReduction * last_shift);
      while (true) {
        ++out.factorizations;
        ++out.inertia_corrections;
        if (kkt.factorize(H, *J, sigma_diag, shift)) break;
        shift *= last_shift == 0.0 ? kFirstShiftGrowth : kShiftGrowth;
        if (shift > kLargestShift) {
          out.status = Status::NumericalError;
          out.message = "no inertia correction made the KKT matrix factorizable";
          return out;
        }
      }
      last_shift = shift;
    }
    previous_shift = shift;
    shifted_steps = shift > 0.0 ? shifted_steps + 1 : 0;
    // Mehrotra's predictor: the affine step (mu = 0) sets mu from the
    // complementarity it would reach, and its second-order term corrects.
    corrector.setZero(m);
    if (free_mode && m > 0) {
      rhs.head(n) = -g;
      rhs.tail(mc) = -here.c;
      kkt.solve(rhs, solution);
      ds_affine = S.cwiseProduct(solution.segment(nq, m));
      dv_affine = -v - v.cwiseQuotient(here.d).cwiseProduct(ds_affine);
      const Eigen::VectorXd& ds = ds_affine;
      double alpha_p = 1.0, alpha_d = 1.0;
      for (int e = 0; e < m; ++e) {
        if (ds[e] < 0.0) alpha_p = std::min(alpha_p, -here.d[e] / ds[e]);
        if (dv_affine[e] < 0.0) alpha_d = std::min(alpha_d, -v[e] / dv_affine[e]);
      }
      const double mu_now = here.d.dot(v) / m;
      const double mu_affine = (here.d + alpha_p * ds).dot(v + alpha_d * dv_affine) / m;
      mu = std::clamp(mu_now * std::pow(mu_affine / mu_now, 3.0), mu_min, std::max(mu_min, mu_now));
      corrector = ds.cwiseProduct(dv_affine);
    }
    // Filter line search on (theta, phi_mu) = (|c|_1, phi - mu sum log d)
    // along dy from alpha_max; the accepted point in y_trial and `trial`.
    auto filter_line_search = [&](double alpha_max, double tau, double theta, double phi, double slope,
                                  bool& objective_step, double& alpha) {
      auto acceptable = [&](const MeritPoint& t, double a) {
        if (!t.inside) return false;
        const double theta_t = t.infeasibility, phi_t = t.objective + mu * t.barrier;
        if (!std::isfinite(phi_t) || theta_t > theta_max) return false;
        for (const auto& [theta_f, phi_f] : filter)
          if (theta_t >= theta_f && phi_t >= phi_f) return false;
        objective_step = theta <= theta_min && slope < 0.0 &&
                         a * std::pow(-slope, kSwitchingObjectiveExponent) >
                             std::pow(theta, kSwitchingInfeasibilityExponent);
        if (objective_step) return phi_t <= phi + kArmijo * a * slope;
        return theta_t <= (1.0 - kFilterInfeasibilityMargin) * theta ||
               phi_t <= phi - kFilterObjectiveMargin * theta;
      };
      alpha = alpha_max;
      for (int backtrack = 0; backtrack < kMaxBacktracks && alpha >= kSmallestStep; ++backtrack, alpha *= 0.5) {
        y_trial = y + alpha * dy;
        evaluate(problem, y_trial, trial);
        if (acceptable(trial, alpha)) return true;
        if (backtrack == 0 && trial.inside) {
          // Second-order correction: back onto the constraints in the W metric.
          rhs_soc.setZero();
          rhs_soc.tail(mc) = -trial.c;
          kkt.solve(rhs_soc, soc);
          y_soc = y_trial + soc.head(n);
          evaluate(problem, y_soc, corrected);
          const bool keeps_fraction =
              corrected.inside && (corrected.d.array() >= (1.0 - tau) * here.d.array()).all();
          if (keeps_fraction && acceptable(corrected, alpha)) {
            y_trial = y_soc;
            std::swap(trial, corrected);
            ++out.second_order_corrections;
            return true;
          }
        }
      }
      return false;
    };

    // The corrected step, and when its line search fails the plain barrier
    // step for the same mu: Mehrotra's second-order term can turn the step
    // away from descent on the barrier objective, the Newton step cannot.
    double theta = here.infeasibility, phi = 0.0, slope = 0.0, alpha = 0.0, alpha_v = 1.0, tau = 1.0;
    bool accepted = false, objective_step = false;
    if (mu != filter_mu) filter.clear(), filter_mu = mu;
    for (int attempt = 0; attempt < 2 && !accepted; ++attempt) {
      if (attempt == 1) {
        if (corrector.isZero(0.0)) break;
        corrector.setZero();
      }
      rhs.head(n) = -g;
      rhs.segment(nq, m) += S.cwiseProduct((mu - corrector.array()).matrix().cwiseQuotient(here.d));
      rhs.tail(mc) = -here.c;
      kkt.solve(rhs, solution);
      if (!solution.allFinite()) {
        out.status = Status::NumericalError;
        out.message = "the Newton step is not finite";
        return out;
      }
      dy = solution.head(n);
      lambda_plus = solution.tail(mc);
      dv = (mu - corrector.array()).matrix().cwiseQuotient(here.d) - v -
           v.cwiseQuotient(here.d).cwiseProduct(S.cwiseProduct(dy.tail(m)));

      // Fraction to the boundary, for the bounded variables and for their multipliers.
      tau = std::max(kSmallestFractionToBoundary, 1.0 - mu);
      double alpha_max = 1.0;
      alpha_v = 1.0;
      for (int e = 0; e < m; ++e) {
        const double dd = S[e] * dy[nq + e];
        if (dd < 0.0) alpha_max = std::min(alpha_max, -tau * here.d[e] / dd);
        if (dv[e] < 0.0) alpha_v = std::min(alpha_v, -tau * v[e] / dv[e]);
      }
      phi = here.objective + mu * here.barrier;
      slope = g.dot(dy) - mu * S.cwiseQuotient(here.d).dot(dy.tail(m));
      accepted = filter_line_search(alpha_max, tau, theta, phi, slope, objective_step, alpha);
    }
    if (!accepted) {
      out.status = Status::Stalled;
      out.message = "the filter line search found no acceptable step";
      project_last_iterate(iteration);
      return out;
    }
    if (!objective_step)
      filter.emplace_back((1.0 - kFilterInfeasibilityMargin) * theta, phi - kFilterObjectiveMargin * theta);

    y = y_trial;
    std::swap(here, trial);
    lambda += alpha * (lambda_plus - lambda);
    v += alpha_v * dv;
    for (int e = 0; e < m; ++e) {
      const double low = mu / (kMultiplierSafeguard * here.d[e]), high = kMultiplierSafeguard * mu / here.d[e];
      v[e] = std::clamp(v[e], low, high);
    }
    objective_history.push_back(here.objective);
    problem.gradient(y, g);
    J = &problem.jacobian(y);
    if (observer) observer(iteration + 1, y);
  }
}

}  // namespace tensegrity
