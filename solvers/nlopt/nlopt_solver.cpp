#include "solvers/nlopt/nlopt_solver.hpp"

#include <Eigen/Geometry>
#include <nlopt.hpp>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <new>
#include <sstream>
#include <stdexcept>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "formulations/free_nodes.hpp"
#include "formulations/minimal_geometry_change_nlp.hpp"
#include "kernels/stress_qp.hpp"
#include "model/errors.hpp"
#include "model/verify.hpp"
#include "solvers/option_reader.hpp"
#include "solvers/trace_recorder.hpp"

namespace tensegrity {
namespace {

enum class Algorithm { AlLbfgs, AlTnewton, AlMma, AlCcsaq, PenaltyLbfgs, AuglagEqLbfgs, Slsqp };

struct AlgorithmEntry {
  const char* name;
  Algorithm algorithm;
};

constexpr AlgorithmEntry kAlgorithms[] = {
    {"al-lbfgs", Algorithm::AlLbfgs},       {"al-tnewton", Algorithm::AlTnewton},
    {"al-mma", Algorithm::AlMma},           {"al-ccsaq", Algorithm::AlCcsaq},
    {"penalty-lbfgs", Algorithm::PenaltyLbfgs}, {"auglag-eq-lbfgs", Algorithm::AuglagEqLbfgs},
    {"slsqp", Algorithm::Slsqp},
};

const char* algorithm_name(Algorithm a) {
  for (const auto& e : kAlgorithms)
    if (e.algorithm == a) return e.name;
  return "?";
}

// NloptOptions resolved for one solve: the algorithm as an enum and the
// evaluation budget as a number.
struct NloptRun {
  Algorithm algorithm = Algorithm::AlLbfgs;
  double ftol_rel = 1e-15;
  double xtol_rel = 1e-15;
  long maxeval = 0;
  double penalty_initial = 10.0;
  double penalty_growth = 10.0;
  double penalty_max = 1e12;
  int lbfgs_memory = 0;
  bool init_from_qp = true;
};

// Evaluations per iteration of the budget when maxeval is not given.
constexpr long kEvaluationsPerIteration = 100;
constexpr long kLargestEvaluationBudget = 1L << 30;  // NLopt counts evaluations in an int

NloptRun resolve(const NloptOptions& o, const SolveOptions& options) {
  NloptRun run;
  for (const auto& e : kAlgorithms)
    if (o.algorithm == e.name) run.algorithm = e.algorithm;
  run.ftol_rel = o.ftol_rel;
  run.xtol_rel = o.xtol_rel;
  run.maxeval = o.maxeval > 0 ? o.maxeval
                              : std::min(kEvaluationsPerIteration * options.iteration_budget(kDefaultIterationBudget),
                                         kLargestEvaluationBudget);
  run.penalty_initial = o.penalty_initial;
  run.penalty_growth = o.penalty_growth;
  run.penalty_max = o.penalty_max;
  run.lbfgs_memory = o.lbfgs_memory;
  run.init_from_qp = o.init == "qp";
  return run;
}

// Why we (not NLopt) stopped a run from inside a callback.
enum class ForcedStop { None, TimeLimit, NonFinite, InnerConverged };

// Runs NLopt and returns its result code. The C++ interface reports the
// negative codes as exceptions (mythrow in nlopt.hpp); translating them back to
// the codes they stand for is lossless, so status_from_nlopt below is the one
// place where any NLopt outcome becomes a Status. x keeps NLopt's best point.
nlopt::result run_nlopt(nlopt::opt& opt, std::vector<double>& x) {
  double value = 0.0;
  try {
    return opt.optimize(x, value);
  } catch (const nlopt::roundoff_limited&) {
    return nlopt::ROUNDOFF_LIMITED;
  } catch (const nlopt::forced_stop&) {
    return nlopt::FORCED_STOP;
  } catch (const std::bad_alloc&) {
    return nlopt::OUT_OF_MEMORY;
  } catch (const std::invalid_argument&) {
    return nlopt::INVALID_ARGS;
  } catch (const std::runtime_error&) {
    return nlopt::FAILURE;
  }
}

const char* result_name(nlopt::result r) {
  switch (r) {
    case nlopt::FAILURE: return "FAILURE";
    case nlopt::INVALID_ARGS: return "INVALID_ARGS";
    case nlopt::OUT_OF_MEMORY: return "OUT_OF_MEMORY";
    case nlopt::ROUNDOFF_LIMITED: return "ROUNDOFF_LIMITED";
    case nlopt::FORCED_STOP: return "FORCED_STOP";
    case nlopt::SUCCESS: return "SUCCESS";
    case nlopt::STOPVAL_REACHED: return "STOPVAL_REACHED";
    case nlopt::FTOL_REACHED: return "FTOL_REACHED";
    case nlopt::XTOL_REACHED: return "XTOL_REACHED";
    case nlopt::MAXEVAL_REACHED: return "MAXEVAL_REACHED";
    case nlopt::MAXTIME_REACHED: return "MAXTIME_REACHED";
    default: return "UNKNOWN";
  }
}

// The one mapping from an NLopt outcome to our Status. A result is converged
// only when the contract's equilibrium check accepts it, whatever NLopt said
// (a roundoff-limited stop on an equilibrium is still an equilibrium). A
// convergence stop (SUCCESS, FTOL, XTOL, STOPVAL) that the check rejects is a
// stall: NLopt's own tests stopped it short of equilibrium, which proves nothing.
Status status_from_nlopt(nlopt::result code, ForcedStop forced, const Verification& check) {
  if (check.ok) return Status::Converged;
  if (!check.all_finite || forced == ForcedStop::NonFinite) return Status::NumericalError;
  if (forced == ForcedStop::TimeLimit || code == nlopt::MAXTIME_REACHED) return Status::TimeLimit;
  switch (code) {
    case nlopt::MAXEVAL_REACHED:
      return Status::MaxIterations;
    case nlopt::SUCCESS:
    case nlopt::STOPVAL_REACHED:
    case nlopt::FTOL_REACHED:
    case nlopt::XTOL_REACHED:
      return Status::Stalled;  // NLopt stopped on its own tests without reaching equilibrium
    case nlopt::FORCED_STOP:
      return forced == ForcedStop::InnerConverged ? Status::MaxIterations
                                                  : Status::NumericalError;
    case nlopt::ROUNDOFF_LIMITED:
    case nlopt::FAILURE:
    case nlopt::INVALID_ARGS:
    case nlopt::OUT_OF_MEMORY:
    default:
      return Status::NumericalError;
  }
}

// Eq. 5 in dimensionless variables y = z ./ D (D = L on positions, F0 on
// forces) with constraints weighted to be dimensionless (1 / F0 on equilibrium
// rows, 1 / (n_c F0) on the normalisation row). Buffers are allocated once.
class ScaledProblem {
 public:
  ScaledProblem(const Structure& part, const ForceScale& scale)
      : nlp_(part, scale), reference_force_(scale.reference_force) {
    n_ = nlp_.num_variables();
    num_constraints_ = nlp_.num_constraints();
    num_positions_ = nlp_.num_positions();
    length_ = nlp_.length_scale();
    unit_.resize(n_);
    unit_.head(num_positions_).setConstant(length_);
    unit_.tail(n_ - num_positions_).setConstant(reference_force_);
    row_weight_ = Eigen::VectorXd::Constant(num_constraints_, 1.0 / reference_force_);
    for (int r = num_positions_; r < num_constraints_; ++r)
      row_weight_[r] = 1.0 / (reference_force_ * std::max(1, scale.num_cables));
    nlp_.jacobian_structure(jac_rows_, jac_cols_);
    jac_values_.resize(nlp_.jacobian_nonzeros());
    z_.resize(n_);
    gradient_.resize(n_);
    raw_constraints_.resize(num_constraints_);
    Eigen::VectorXd lo, hi;
    nlp_.constraint_bounds(lo, hi);
    constraint_target_ = lo;
    // Under gravity the cable-sum row is the equality c^T sigma = cap of the
    // Eq. 5 formulation (an equality, like the normalisation without gravity).
    nlp_.variable_bounds(lo, hi);
    lower_.resize(n_);
    upper_.resize(n_);
    for (int i = 0; i < n_; ++i) {
      lower_[i] = std::isfinite(lo[i]) ? lo[i] / unit_[i] : -HUGE_VAL;
      upper_[i] = std::isfinite(hi[i]) ? hi[i] / unit_[i] : HUGE_VAL;
    }
    // The contract's load scale: the largest free-node weight, when there is one.
    const Eigen::Matrix3Xd loads = part.gravity_loads();
    for (int i = 0; i < part.num_nodes(); ++i)
      if (!part.fixed[i]) gravity_load_scale_ = std::max(gravity_load_scale_, loads.col(i).norm());
  }

  int num_variables() const { return n_; }
  int num_constraints() const { return num_constraints_; }
  int num_positions() const { return num_positions_; }
  double length() const { return length_; }
  double reference_force() const { return reference_force_; }
  const std::vector<double>& lower() const { return lower_; }
  const std::vector<double>& upper() const { return upper_; }
  MinimalGeometryChangeNlp& nlp() { return nlp_; }

  Eigen::VectorXd to_scaled(const Eigen::VectorXd& z) const { return z.cwiseQuotient(unit_); }
  Eigen::VectorXd to_unscaled(const double* y) const {
    return Eigen::Map<const Eigen::VectorXd>(y, n_).cwiseProduct(unit_);
  }

  double objective(const double* y) {
    set(y);
    return nlp_.objective(z_);
  }
  // grad = d objective / dy.
  void gradient(const double* y, double* grad) {
    set(y);
    nlp_.gradient(z_, gradient_);
    Eigen::Map<Eigen::VectorXd>(grad, n_) = gradient_.cwiseProduct(unit_);
  }
  // c = scaled constraints at y.
  void constraints(const double* y, double* c) {
    set(y);
    nlp_.constraints(z_, raw_constraints_);
    Eigen::Map<Eigen::VectorXd>(c, num_constraints_) =
        (raw_constraints_ - constraint_target_).cwiseProduct(row_weight_);
    if (cap_row_ >= 0) c[cap_row_] = std::max(0.0, c[cap_row_]);
  }
  // Whether Jacobian row r is zero at the current point (the hinge of the
  // prestress cap below the cap).
  bool row_inactive(int r) const {
    return r == cap_row_ &&
           nlp_.force_scale().normalisation_row.dot(z_.tail(n_ - num_positions_)) <= constraint_target_[r];
  }
  // grad += (dc/dy)^T v.
  void add_jacobian_transpose_times(const double* y, const double* v, double* grad) {
    set(y);
    nlp_.jacobian_values(z_, jac_values_.data());
    const bool skip_cap = cap_row_ >= 0 && row_inactive(cap_row_);
    for (std::size_t k = 0; k < jac_values_.size(); ++k) {
      const int r = jac_rows_[k], col = jac_cols_[k];
      if (skip_cap && r == cap_row_) continue;
      grad[col] += jac_values_[k] * row_weight_[r] * v[r] * unit_[col];
    }
  }
  // Dense row-major Jacobian of the scaled constraints (what NLopt's
  // mconstraint interface asks for).
  void dense_jacobian(const double* y, double* jac) {
    set(y);
    nlp_.jacobian_values(z_, jac_values_.data());
    std::fill(jac, jac + static_cast<std::size_t>(num_constraints_) * n_, 0.0);
    const bool skip_cap = cap_row_ >= 0 && row_inactive(cap_row_);
    for (std::size_t k = 0; k < jac_values_.size(); ++k) {
      const int r = jac_rows_[k], col = jac_cols_[k];
      if (skip_cap && r == cap_row_) continue;
      jac[static_cast<std::size_t>(r) * n_ + col] += jac_values_[k] * row_weight_[r] * unit_[col];
    }
  }

  // The contract's residual (N) and relative residual from scaled constraints.
  double residual(const double* c) const {
    double worst = 0.0;
    for (int k = 0; k + 2 < num_positions_; k += 3)
      worst = std::max(worst, std::sqrt(c[k] * c[k] + c[k + 1] * c[k + 1] + c[k + 2] * c[k + 2]));
    return worst * reference_force_;
  }
  double relative_residual(const double* c, const double* y) const {
    double scale = gravity_load_scale_;
    if (!(scale > 0.0)) {
      for (int i = num_positions_; i < n_; ++i) scale = std::max(scale, std::abs(y[i]));
      scale *= reference_force_;
    }
    const double r = residual(c);
    return scale > 0.0 ? r / scale : r;
  }
  // |mean cable force / F0 - 1|, zero without cables.
  double normalisation_error(const double* c) const {
    double worst = 0.0;
    for (int r = num_positions_; r < num_constraints_; ++r) worst = std::max(worst, std::abs(c[r]));
    return worst;
  }
  double geometry_change(const double* y, const Eigen::VectorXd& y0) const {
    double sum = 0.0;
    for (int i = 0; i < num_positions_; ++i) sum += (y[i] - y0[i]) * (y[i] - y0[i]);
    return length_ * std::sqrt(sum);
  }
  // Target on |scaled equilibrium row| that meets relative residual `rr`.
  double absolute_target(double rr) const {
    const double scale = gravity_load_scale_ > 0.0 ? gravity_load_scale_ : reference_force_;
    return rr * scale / reference_force_;
  }

 private:
  void set(const double* y) {
    z_ = Eigen::Map<const Eigen::VectorXd>(y, n_).cwiseProduct(unit_);
  }

  MinimalGeometryChangeNlp nlp_;
  double reference_force_ = 1.0;
  double length_ = 1.0;
  double gravity_load_scale_ = 0.0;
  int n_ = 0, num_constraints_ = 0, num_positions_ = 0;
  int cap_row_ = -1;  // the prestress cap's row under gravity, else -1
  Eigen::VectorXd unit_, row_weight_, constraint_target_, z_, gradient_, raw_constraints_;
  std::vector<int> jac_rows_, jac_cols_;
  std::vector<double> jac_values_;
  std::vector<double> lower_, upper_;
};

// What a run ended with: NLopt's last code, our own forced stop, counters.
struct RunEnd {
  nlopt::result code = nlopt::FAILURE;
  ForcedStop forced = ForcedStop::None;
  long evaluations = 0;
  int iterations = 0;
};

// ---------------------------------------------------------------------------
// Augmented Lagrangian (or penalty) outer loop around a bound-constrained NLopt
// local algorithm.

struct AlState {
  ScaledProblem* problem = nullptr;
  nlopt::opt* opt = nullptr;
  TraceRecorder* recorder = nullptr;
  Eigen::VectorXd lambda, c, weight;  // weight = lambda + rho c
  double rho = 1.0;
  double omega = 1e-3;                // projected-gradient tolerance of this inner solve
  long evaluations = 0;
  ForcedStop forced = ForcedStop::None;
  std::vector<double> stationary_point;
};

double augmented_lagrangian(unsigned n, const double* y, double* grad, void* data) {
  auto& s = *static_cast<AlState*>(data);
  ++s.evaluations;
  if (s.recorder->out_of_time()) {
    s.forced = ForcedStop::TimeLimit;
    s.opt->force_stop();
    return HUGE_VAL;
  }
  ScaledProblem& p = *s.problem;
  const double objective = p.objective(y);
  p.constraints(y, s.c.data());
  s.weight = s.lambda + s.rho * s.c;
  const double value = objective + s.lambda.dot(s.c) + 0.5 * s.rho * s.c.squaredNorm();
  if (!std::isfinite(value)) {
    s.forced = ForcedStop::NonFinite;
    s.opt->force_stop();
    return HUGE_VAL;
  }
  if (grad != nullptr) {
    p.gradient(y, grad);
    p.add_jacobian_transpose_times(y, s.weight.data(), grad);
    // Projected gradient: NLopt's local algorithms have no gradient test, so
    // the inner solve stops here once it is stationary enough.
    double projected = 0.0;
    const auto& lo = p.lower();
    const auto& hi = p.upper();
    for (unsigned i = 0; i < n; ++i) {
      const double g = grad[i];
      if (!std::isfinite(g)) {
        s.forced = ForcedStop::NonFinite;
        s.opt->force_stop();
        return HUGE_VAL;
      }
      if ((y[i] <= lo[i] && g > 0.0) || (y[i] >= hi[i] && g < 0.0)) continue;
      projected = std::max(projected, std::abs(g));
    }
    if (projected <= s.omega) {
      s.stationary_point.assign(y, y + n);
      s.forced = ForcedStop::InnerConverged;
      s.opt->force_stop();
    }
  }
  return value;
}

nlopt::algorithm local_algorithm(Algorithm a) {
  switch (a) {
    case Algorithm::AlTnewton: return nlopt::LD_TNEWTON_PRECOND_RESTART;
    case Algorithm::AlMma: return nlopt::LD_MMA;
    case Algorithm::AlCcsaq: return nlopt::LD_CCSAQ;
    default: return nlopt::LD_LBFGS;
  }
}

RunEnd run_augmented_lagrangian(ScaledProblem& p, std::vector<double>& y,
                                const NloptRun& o, const SolveOptions& so,
                                TraceRecorder& recorder) {
  const int n = p.num_variables();
  const bool multipliers = o.algorithm != Algorithm::PenaltyLbfgs;
  const double target = 0.5 * so.tolerance;
  const Eigen::VectorXd y0 = Eigen::Map<const Eigen::VectorXd>(y.data(), n);

  nlopt::opt inner(local_algorithm(o.algorithm), static_cast<unsigned>(n));
  inner.set_lower_bounds(p.lower());
  inner.set_upper_bounds(p.upper());
  inner.set_ftol_rel(o.ftol_rel);
  inner.set_xtol_rel(o.xtol_rel);
  if (o.lbfgs_memory > 0) inner.set_vector_storage(static_cast<unsigned>(o.lbfgs_memory));

  AlState s;
  s.problem = &p;
  s.opt = &inner;
  s.recorder = &recorder;
  s.lambda = Eigen::VectorXd::Zero(p.num_constraints());
  s.c.resize(p.num_constraints());
  s.weight.resize(p.num_constraints());
  s.rho = o.penalty_initial;
  inner.set_min_objective(augmented_lagrangian, &s);

  Eigen::VectorXd c(p.num_constraints());
  p.constraints(y.data(), c.data());
  double violation = c.lpNorm<Eigen::Infinity>();
  double previous_violation = violation;
  int stalled = 0;
  RunEnd end;
  // Normalisation accurate enough that every backend's forces compare.
  const double normalisation_target = 1e-10;
  auto accepted = [&](const double* at) {
    return p.relative_residual(c.data(), at) <= target &&
           p.normalisation_error(c.data()) <= normalisation_target;
  };
  if (accepted(y.data())) {  // already in equilibrium: do not move it
    end.code = nlopt::SUCCESS;
    return end;
  }
  end.code = nlopt::MAXEVAL_REACHED;
  const int outer_budget = so.iteration_budget(kDefaultIterationBudget);
  for (int outer = 0; outer < outer_budget; ++outer) {
    const double remaining_time = so.time_limit_s - recorder.seconds();
    if (remaining_time <= 0.0) {
      end.code = nlopt::MAXTIME_REACHED;
      break;
    }
    if (s.evaluations >= o.maxeval) {
      end.code = nlopt::MAXEVAL_REACHED;
      break;
    }
    inner.set_maxtime(remaining_time);
    inner.set_maxeval(static_cast<int>(std::min<long>(o.maxeval - s.evaluations, 1L << 30)));
    s.omega = std::clamp(0.1 * violation, 1e-11, 1e-2);
    s.forced = ForcedStop::None;
    nlopt::result code = run_nlopt(inner, y);
    if (s.forced == ForcedStop::InnerConverged) {
      y = s.stationary_point;
      code = nlopt::SUCCESS;
    }
    end.iterations = outer + 1;
    end.code = code;
    end.forced = s.forced;

    p.constraints(y.data(), c.data());
    violation = c.lpNorm<Eigen::Infinity>();
    TracePoint t;
    t.iteration = outer + 1;
    t.evaluations = static_cast<int>(std::min<long>(s.evaluations, std::numeric_limits<int>::max()));
    t.residual = p.residual(c.data());
    t.relative_residual = p.relative_residual(c.data(), y.data());
    t.geometry_change = p.geometry_change(y.data(), y0);
    t.objective = p.objective(y.data());
    recorder.record(t);

    if (!std::isfinite(violation)) {
      end.forced = ForcedStop::NonFinite;
      break;
    }
    if (accepted(y.data())) {
      end.code = nlopt::SUCCESS;
      end.forced = ForcedStop::None;
      break;
    }
    if (s.forced == ForcedStop::TimeLimit || s.forced == ForcedStop::NonFinite ||
        code == nlopt::MAXTIME_REACHED || code == nlopt::OUT_OF_MEMORY ||
        code == nlopt::INVALID_ARGS) {
      break;
    }
    if (code == nlopt::MAXEVAL_REACHED && s.evaluations >= o.maxeval) break;

    if (multipliers) s.lambda += s.rho * c;
    const bool progress = violation <= 0.25 * previous_violation;
    if (!progress || !multipliers) s.rho = std::min(s.rho * o.penalty_growth, o.penalty_max);
    // At the largest penalty without progress: a stationary point of the
    // infeasibility, not an equilibrium.
    stalled = (s.rho >= o.penalty_max && violation > 0.9 * previous_violation) ? stalled + 1 : 0;
    if (stalled >= 3) {
      end.code = nlopt::XTOL_REACHED;
      break;
    }
    previous_violation = violation;
    if (outer + 1 == outer_budget) {  // the outer budget ran out
      end.code = nlopt::MAXEVAL_REACHED;
      end.forced = ForcedStop::None;
    }
  }
  end.evaluations = s.evaluations;
  return end;
}

// ---------------------------------------------------------------------------
// NLopt's own constrained algorithms (SLSQP, AUGLAG_EQ) on the scaled Eq. 5.

// Without fixed nodes (and so without gravity) the equilibrium rows obey six
// identities for every (x, sigma): the net force and the net moment of all
// nodal residuals vanish. SLSQP needs a Jacobian of full row rank, so six rows
// are left out: nodes a, b, c (free, not collinear) keep only the projections
// f_b . e_b and f_c . e_1, f_c . e_2, with e_b along x_b - x_a and e_1, e_2
// spanning the plane of a, b, c, all frozen at the scene geometry. With every
// other row zero the identities force f_c into the current plane of a, b, c
// and f_b along x_b - x_a, so the kept projections vanish only when f_a, f_b
// and f_c do, as long as the geometry does not turn by 90 degrees.
struct RowCombination {
  int rows[3] = {0, 0, 0};
  double weights[3] = {0.0, 0.0, 0.0};
  int count = 0;
};

std::vector<RowCombination> independent_rows(const Structure& part, int num_constraints) {
  std::vector<RowCombination> kept;
  auto keep_row = [&](int r) {
    RowCombination c;
    c.rows[0] = r;
    c.weights[0] = 1.0;
    c.count = 1;
    kept.push_back(c);
  };
  const int nf = part.num_free_nodes();
  if (nf < 3 || part.num_nodes() != nf) {  // fixed nodes (or none given): no identities
    for (int r = 0; r < num_constraints; ++r) keep_row(r);
    return kept;
  }
  const FreeNodeMap map(part);
  const auto& free = map.free_nodes();
  const int a = 0, b = 1;
  const Eigen::Vector3d xa = part.positions.col(free[a]);
  const Eigen::Vector3d db = part.positions.col(free[b]) - xa;
  int c = 2;
  double best = -1.0;
  for (int k = 2; k < nf; ++k) {
    const double area = db.cross(part.positions.col(free[k]) - xa).norm();
    if (area > best) best = area, c = k;
  }
  const Eigen::Vector3d eb = db.normalized();
  const Eigen::Vector3d normal = db.cross(part.positions.col(free[c]) - xa).normalized();
  const Eigen::Vector3d e1 = (part.positions.col(free[c]) - xa).normalized();
  const Eigen::Vector3d e2 = normal.cross(e1);
  auto keep_projection = [&](int slot, const Eigen::Vector3d& e) {
    RowCombination comb;
    for (int i = 0; i < 3; ++i) comb.rows[i] = 3 * slot + i, comb.weights[i] = e[i];
    comb.count = 3;
    kept.push_back(comb);
  };
  for (int k = 0; k < nf; ++k) {
    if (k == a) continue;
    if (k == b) {
      keep_projection(b, eb);
    } else if (k == c) {
      keep_projection(c, e1);
      keep_projection(c, e2);
    } else {
      for (int i = 0; i < 3; ++i) keep_row(3 * k + i);
    }
  }
  for (int r = 3 * nf; r < num_constraints; ++r) keep_row(r);
  return kept;
}

struct DirectState {
  ScaledProblem* problem = nullptr;
  nlopt::opt* opt = nullptr;
  TraceRecorder* recorder = nullptr;
  Eigen::VectorXd y0;
  long evaluations = 0;
  int constraint_evaluations = 0;
  ForcedStop forced = ForcedStop::None;
  std::vector<RowCombination> rows;  // the constraints NLopt sees
  std::vector<double> full_c, full_jacobian;
};

double direct_objective(unsigned, const double* y, double* grad, void* data) {
  auto& s = *static_cast<DirectState*>(data);
  ++s.evaluations;
  if (s.recorder->out_of_time()) {
    s.forced = ForcedStop::TimeLimit;
    s.opt->force_stop();
    return HUGE_VAL;
  }
  const double value = s.problem->objective(y);
  if (grad != nullptr) s.problem->gradient(y, grad);
  if (!std::isfinite(value)) {
    s.forced = ForcedStop::NonFinite;
    s.opt->force_stop();
    return HUGE_VAL;
  }
  return value;
}

void direct_constraints(unsigned m, double* result, unsigned, const double* y, double* grad,
                        void* data) {
  auto& s = *static_cast<DirectState*>(data);
  ScaledProblem& p = *s.problem;
  const std::size_t n = static_cast<std::size_t>(p.num_variables());
  p.constraints(y, s.full_c.data());
  if (grad != nullptr) p.dense_jacobian(y, s.full_jacobian.data());
  for (unsigned r = 0; r < m; ++r) {
    const RowCombination& comb = s.rows[r];
    result[r] = 0.0;
    for (int k = 0; k < comb.count; ++k) result[r] += comb.weights[k] * s.full_c[comb.rows[k]];
    if (grad == nullptr) continue;
    double* out = grad + r * n;
    std::fill(out, out + n, 0.0);
    for (int k = 0; k < comb.count; ++k) {
      const double* in = s.full_jacobian.data() + comb.rows[k] * n;
      for (std::size_t j = 0; j < n; ++j) out[j] += comb.weights[k] * in[j];
    }
  }
  ++s.constraint_evaluations;
  TracePoint t;
  t.iteration = s.constraint_evaluations;
  t.evaluations = static_cast<int>(std::min<long>(s.evaluations, std::numeric_limits<int>::max()));
  t.residual = p.residual(s.full_c.data());
  t.relative_residual = p.relative_residual(s.full_c.data(), y);
  t.geometry_change = p.geometry_change(y, s.y0);
  t.objective = p.objective(y);
  s.recorder->record(t);
  for (unsigned i = 0; i < m; ++i) {
    if (!std::isfinite(result[i])) {
      s.forced = ForcedStop::NonFinite;
      s.opt->force_stop();
      return;
    }
  }
}

RunEnd run_direct(const Structure& part, ScaledProblem& p, std::vector<double>& y,
                  const NloptRun& o, const SolveOptions& so, TraceRecorder& recorder) {
  const unsigned n = static_cast<unsigned>(p.num_variables());
  const bool auglag = o.algorithm == Algorithm::AuglagEqLbfgs;
  nlopt::opt opt(auglag ? nlopt::AUGLAG_EQ : nlopt::LD_SLSQP, n);
  DirectState s;
  s.problem = &p;
  s.opt = &opt;
  s.recorder = &recorder;
  s.y0 = Eigen::Map<const Eigen::VectorXd>(y.data(), n);
  // AUGLAG_EQ only penalises the rows, so it keeps them all.
  s.rows = auglag ? independent_rows(Structure{}, p.num_constraints())
                  : independent_rows(part, p.num_constraints());
  s.full_c.resize(p.num_constraints());
  s.full_jacobian.resize(static_cast<std::size_t>(p.num_constraints()) * n);
  opt.set_lower_bounds(p.lower());
  opt.set_upper_bounds(p.upper());
  opt.set_min_objective(direct_objective, &s);
  const std::vector<double> tolerances(s.rows.size(),
                                       p.absolute_target(0.25 * so.tolerance));
  opt.add_equality_mconstraint(direct_constraints, &s, tolerances);
  opt.set_ftol_rel(o.ftol_rel);
  opt.set_xtol_rel(o.xtol_rel);
  opt.set_maxeval(static_cast<int>(std::min<long>(o.maxeval, 1L << 30)));
  opt.set_maxtime(std::max(1e-3, so.time_limit_s - recorder.seconds()));
  if (auglag) {
    nlopt::opt local(nlopt::LD_LBFGS, n);
    local.set_ftol_rel(o.ftol_rel);
    local.set_xtol_rel(o.xtol_rel);
    if (o.lbfgs_memory > 0) local.set_vector_storage(static_cast<unsigned>(o.lbfgs_memory));
    opt.set_local_optimizer(local);
  }
  RunEnd end;
  end.code = run_nlopt(opt, y);
  end.forced = s.forced;
  end.evaluations = s.evaluations;
  end.iterations = s.constraint_evaluations;
  return end;
}

void fill_stats(SolveResult& r, const Verification& v, int iterations, double seconds) {
  r.stats.iterations = iterations;
  r.stats.seconds = seconds;
  r.stats.residual = v.residual;
  r.stats.relative_residual = v.relative_residual;
  r.stats.geometry_change = v.geometry_change;
}

}  // namespace

std::vector<std::string> NloptSolver::algorithm_names() {
  std::vector<std::string> names;
  for (const auto& e : kAlgorithms) names.emplace_back(e.name);
  return names;
}

NloptOptions NloptOptions::FromPairs(const OptionPairs& pairs) {
  OptionReader reader(pairs, "nlopt");
  NloptOptions o;
  o.algorithm = reader.choice("algorithm", o.algorithm, NloptSolver::algorithm_names());
  o.ftol_rel = reader.number("ftol_rel", o.ftol_rel, ValueRange::positive());
  o.xtol_rel = reader.number("xtol_rel", o.xtol_rel, ValueRange::positive());
  o.maxeval = reader.integer("maxeval", static_cast<int>(o.maxeval), 1, static_cast<int>(kLargestEvaluationBudget));
  o.penalty_initial = reader.number("penalty_initial", o.penalty_initial, ValueRange::positive());
  o.penalty_growth = reader.number("penalty_growth", o.penalty_growth, ValueRange::open(1.0, std::numeric_limits<double>::infinity()));
  o.penalty_max = reader.number("penalty_max", o.penalty_max, ValueRange::positive());
  o.lbfgs_memory = reader.integer("lbfgs_memory", o.lbfgs_memory, 0, kLargestLbfgsMemory);
  o.init = reader.choice("init", o.init, {"qp", "reference"});
  reader.reject_unknown();
  if (o.penalty_max < o.penalty_initial) reader.fail("penalty_max", "must be at least penalty_initial");
  return o;
}

bool NloptOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  const auto names = NloptSolver::algorithm_names();
  if (std::find(names.begin(), names.end(), algorithm) == names.end()) return fail("unknown algorithm");
  if (!(ftol_rel > 0.0 && xtol_rel > 0.0)) return fail("ftol_rel and xtol_rel must be > 0");
  if (maxeval < 0 || maxeval > kLargestEvaluationBudget) return fail("maxeval must be in [0, 2^30]");
  if (!(penalty_initial > 0.0 && penalty_growth > 1.0 && penalty_max >= penalty_initial))
    return fail("penalty_initial > 0, penalty_growth > 1 and penalty_max >= penalty_initial");
  if (lbfgs_memory < 0 || lbfgs_memory > kLargestLbfgsMemory) return fail("lbfgs_memory must be in [0, 1000]");
  if (init != "qp" && init != "reference") return fail("init must be qp or reference");
  return true;
}

SolveResult NloptSolver::DoSolve(const PartProblem& problem, const NloptOptions& nlopt_options) const {
  const Structure& part = problem.part;
  const SolveOptions& options = problem.options;
  const NloptRun o = resolve(nlopt_options, options);
  TraceRecorder recorder(options.time_limit_s);
  const ForceScale scale = make_force_scale(part, options.margin_fraction, options.prestress_factor);
  SolveResult result;

  // Sigma_0: the stress QP at the scene geometry is the natural warm start;
  // the reference forces when asked for or when the QP gives nothing usable.
  Eigen::VectorXd sigma0 = reference_forces(part, scale);
  if (o.init_from_qp) {
    Equilibrium eq(part);
    StressQp qp(eq, scale);
    const StressQpResult s = qp.solve();
    if (s.sigma.size() == sigma0.size() && s.sigma.allFinite()) sigma0 = s.sigma;
  }

  ScaledProblem scaled(part, scale);
  const Eigen::VectorXd y0 = scaled.to_scaled(scaled.nlp().initial_point(sigma0));
  std::vector<double> y(y0.data(), y0.data() + y0.size());
  // Keep the start inside NLopt's box (it rejects points outside it).
  for (std::size_t i = 0; i < y.size(); ++i)
    y[i] = std::clamp(y[i], scaled.lower()[i], scaled.upper()[i]);

  RunEnd end;
  if (o.algorithm == Algorithm::Slsqp || o.algorithm == Algorithm::AuglagEqLbfgs)
    end = run_direct(part, scaled, y, o, options, recorder);
  else
    end = run_augmented_lagrangian(scaled, y, o, options, recorder);

  const Eigen::VectorXd z = scaled.to_unscaled(y.data());
  result.positions = scaled.nlp().positions(z);
  result.forces = scaled.nlp().forces(z);
  const Verification v = verify(part, result.positions, result.forces, options.tolerance);
  result.status = status_from_nlopt(end.code, end.forced, v);
  result.native_code = static_cast<int>(end.code);
  result.trace = std::move(recorder.trace());
  fill_stats(result, v, end.iterations, recorder.seconds());
  std::ostringstream message;
  message << algorithm_name(o.algorithm) << ": " << to_string(result.status) << " after "
          << end.iterations << " iterations, " << end.evaluations
          << " evaluations (last NLopt result " << result_name(end.code) << ")";
  if (end.forced == ForcedStop::TimeLimit) message << ", time limit";
  if (end.forced == ForcedStop::NonFinite) message << ", non-finite evaluation";
  result.message = message.str();
  return result;
}

std::unique_ptr<Solver> make_nlopt_solver() { return std::make_unique<NloptSolver>(); }

}  // namespace tensegrity
