// NLopt's own constrained algorithms (SLSQP, AUGLAG_EQ) on the full
// formulation's scaled Eq. 5.
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

#include "formulations/free_nodes.hpp"
#include "solvers/nlopt/nlopt_full_problem.hpp"
#include "solvers/nlopt/nlopt_internal.hpp"

namespace tensegrity::nlopt_detail {
namespace {

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

}  // namespace

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


}  // namespace tensegrity::nlopt_detail
