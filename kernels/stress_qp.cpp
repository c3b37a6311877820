#include "kernels/stress_qp.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "kernels/stress_qp_impl.hpp"
#include "model/json_text.hpp"

namespace tensegrity {

bool StressQpOptions::IsValid() const {
  return std::isfinite(mu) && mu > 0.0 && std::isfinite(normalisation_weight) &&
         normalisation_weight >= 0.0 && max_iterations >= 0 && max_polish_steps >= 0 &&
         std::isfinite(optimality_tolerance) && optimality_tolerance > 0.0 && give_up_residual > 0.0;
}

const char* to_string(StressQpStatus status) {
  switch (status) {
    case StressQpStatus::Optimal: return "optimal";
    case StressQpStatus::IterationLimit: return "iteration_limit";
    case StressQpStatus::Stalled: return "stalled";
    case StressQpStatus::Uncertified: return "uncertified";
    case StressQpStatus::NumericalFailure: return "numerical_failure";
  }
  return "numerical_failure";
}

struct StressQp::Impl : stress_qp_detail::Impl {};

namespace stress_qp_detail {

void Impl::build(const SparseMatrix& A, const ForceScale& scale,
                           const StressQpOptions& o) {
  m = static_cast<int>(A.cols());
  rows = static_cast<int>(A.rows());
  mu = o.mu;
  normalised = scale.has_normalisation() && o.normalisation_weight > 0.0 &&
               scale.normalisation_row.size() == m;
  w2 = normalised ? o.normalisation_weight * o.normalisation_weight : 0.0;
  scale_target = normalised ? scale.normalisation_target : 0.0;
  target = scale_target + (normalised ? target_shift : 0.0);
  f0 = scale.reference_force > 0.0 && std::isfinite(scale.reference_force) ? scale.reference_force
                                                                            : 1.0;
  lower = scale.lower.size() == m ? scale.lower : Eigen::VectorXd::Constant(m, -kInf);
  upper = scale.upper.size() == m ? scale.upper : Eigen::VectorXd::Constant(m, kInf);
  c = normalised ? scale.normalisation_row : Eigen::VectorXd::Zero(m);

  // A's columns (row, value offset), read through InnerIterator so that an
  // uncompressed matrix is addressed correctly too.
  a_col_start.assign(m + 1, 0);
  a_row.clear();
  a_value.clear();
  for (int j = 0; j < m; ++j) {
    for (SparseMatrix::InnerIterator it(A, j); it; ++it) {
      a_row.push_back(static_cast<int>(it.row()));
      a_value.push_back(static_cast<int>(&it.value() - A.valuePtr()));
    }
    a_col_start[j + 1] = static_cast<int>(a_row.size());
  }
  node_space = o.node_space;
  if (node_space) build_node_space(A);
  else build_force_space();
  factorization_valid = false;
  held.assign(m, 0);
  factored_held.assign(m, 0);

  for (Eigen::VectorXd* v : {&s, &g, &d, &trial, &step, &rhs, &lin_res, &op_out, &masked, &best_s, &cg_x, &cg_r,
                             &cg_z, &cg_p, &cg_q})
    v->setZero(m);
  correction.setZero(m);
  aug_rhs.setZero(m + 1);
  aug_sol.setZero(m + 1);
  r.setZero(rows);
  a_step.setZero(rows);
}

// K's pattern, the pairs of A values behind each of its values, and its
// symbolic analysis.
void Impl::build_force_space() {
  // Row lists of A: which columns (and value offsets) touch each equation.
  std::vector<int> row_start(rows + 1, 0);
  for (int r : a_row) ++row_start[r + 1];
  for (int i = 0; i < rows; ++i) row_start[i + 1] += row_start[i];
  std::vector<int> row_col(a_row.size()), row_val(a_row.size()), fill(row_start.begin(), row_start.end() - 1);
  for (int j = 0; j < m; ++j) {
    for (int p = a_col_start[j]; p < a_col_start[j + 1]; ++p) {
      const int slot = fill[a_row[p]]++;
      row_col[slot] = j;
      row_val[slot] = a_value[p];
    }
  }

  // Contributions to the lower triangle of A^T A: (col f, row e >= f, A value of e, A value of f).
  struct Contribution { int col, row, va, vb; };
  std::vector<Contribution> contributions;
  for (int f = 0; f < m; ++f) {
    for (int p = a_col_start[f]; p < a_col_start[f + 1]; ++p) {
      const int i = a_row[p];
      for (int q = row_start[i]; q < row_start[i + 1]; ++q) {
        if (row_col[q] >= f) contributions.push_back({f, row_col[q], row_val[q], a_value[p]});
      }
    }
  }

  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(contributions.size() + 2 * m + 1);
  for (const Contribution& t : contributions) triplets.emplace_back(t.row, t.col, 1.0);
  for (int e = 0; e < m; ++e) {
    triplets.emplace_back(e, e, 1.0);
    if (c[e] != 0.0) triplets.emplace_back(m, e, 1.0);
  }
  triplets.emplace_back(m, m, 1.0);
  K.resize(m + 1, m + 1);
  K.setFromTriplets(triplets.begin(), triplets.end());
  K.makeCompressed();

  const int nnz = static_cast<int>(K.nonZeros());
  k_row.resize(nnz);
  k_col.resize(nnz);
  for (int j = 0; j <= m; ++j) {
    for (int k = K.outerIndexPtr()[j]; k < K.outerIndexPtr()[j + 1]; ++k) {
      k_row[k] = K.innerIndexPtr()[k];
      k_col[k] = j;
    }
  }
  auto value_index = [&](int row, int col) {
    const int* begin = K.innerIndexPtr() + K.outerIndexPtr()[col];
    const int* end = K.innerIndexPtr() + K.outerIndexPtr()[col + 1];
    return static_cast<int>(std::lower_bound(begin, end, row) - K.innerIndexPtr());
  };
  pair_start.assign(nnz + 1, 0);
  std::vector<int> owner(contributions.size());
  for (std::size_t t = 0; t < contributions.size(); ++t) {
    owner[t] = value_index(contributions[t].row, contributions[t].col);
    ++pair_start[owner[t] + 1];
  }
  for (int k = 0; k < nnz; ++k) pair_start[k + 1] += pair_start[k];
  pair_a.resize(contributions.size());
  pair_b.resize(contributions.size());
  std::vector<int> next(pair_start.begin(), pair_start.end() - 1);
  for (std::size_t t = 0; t < contributions.size(); ++t) {
    const int slot = next[owner[t]]++;
    pair_a[slot] = contributions[t].va;
    pair_b[slot] = contributions[t].vb;
  }
  base.assign(nnz, 0.0);
  diag_n.setZero(m);

  ldlt.analyze(K);
}

// M's node-block pattern and its analysis (NormalMatrix); J = I in 3x3 blocks.
void Impl::build_node_space(const SparseMatrix& A) {
  std::vector<Eigen::Triplet<double>> identity;
  identity.reserve(3 * static_cast<std::size_t>(rows));
  for (int block = 0; 3 * block + 2 < rows; ++block)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) identity.emplace_back(3 * block + i, 3 * block + j, i == j ? 1.0 : 0.0);
  node_identity.resize(rows, rows);
  node_identity.setFromTriplets(identity.begin(), identity.end());
  node_matrix = std::make_unique<NormalMatrix>(node_identity, A, normalised ? &c : nullptr);
  node_weight.setZero(m);
  held_inverse.setZero(m);
  node_back.setZero(m);
  node_rhs.setZero(node_matrix->size());
  node_sol.setZero(node_matrix->size());
}

// N_ii = |A_i|^2 + w^2 c_i^2 + mu, read from A's values directly.
void Impl::refresh_node_space(const SparseMatrix& A) {
  node_a = &A;
  const double* a = A.valuePtr();
  diag_n.resize(m);
  for (int j = 0; j < m; ++j) {
    double v = mu + w2 * c[j] * c[j];
    for (int p = a_col_start[j]; p < a_col_start[j + 1]; ++p) v += a[a_value[p]] * a[a_value[p]];
    diag_n[j] = v;
  }
  factorization_valid = false;
}

// M = I + B diag(node_weight) B^T, factorized.
bool Impl::factorize_node_space() {
  if (!node_weight.allFinite()) return false;
  constexpr double kIdentityWeight = 1.0;
  constexpr double kNoDiagonalShift = 0.0;
  return node_matrix->assemble_and_factorize(node_identity, kIdentityWeight, *node_a, node_weight, std::sqrt(w2),
                                             kNoDiagonalShift, kIdentityWeight);
}

// x = D^{-1} (b - B^T M^{-1} B D^{-1} b) on the free set, b_i / N_ii on the held one.
void Impl::apply_node_space_inverse(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  const SparseMatrix& A = *node_a;
  const double w = std::sqrt(w2);
  node_back = node_weight.cwiseProduct(b);
  node_rhs.head(rows).noalias() = A * node_back;
  if (normalised) node_rhs[rows] = w * c.dot(node_back);
  node_matrix->solve(node_rhs, node_sol);
  node_back.noalias() = A.transpose() * node_sol.head(rows);
  if (normalised) node_back += (w * node_sol[rows]) * c;
  x = held_inverse.cwiseProduct(b) + node_weight.cwiseProduct(b - node_back);
}

bool Impl::pattern_matches(const SparseMatrix& A) const {
  if (A.cols() != m || A.rows() != rows) return false;
  for (int j = 0; j < m; ++j) {
    int p = a_col_start[j];
    for (SparseMatrix::InnerIterator it(A, j); it; ++it, ++p) {
      if (p >= a_col_start[j + 1] || a_row[p] != it.row() ||
          a_value[p] != static_cast<int>(&it.value() - A.valuePtr()))
        return false;
    }
    if (p != a_col_start[j + 1]) return false;
  }
  return true;
}

// Values of K for an empty held set and the diagonal of N, from A's current
// values. False when the geometry produced non-finite values.
bool Impl::refresh(const SparseMatrix& A) {
  if (node_space) {
    refresh_node_space(A);
    return diag_n.allFinite();
  }
  const double* a = A.valuePtr();
  const int nnz = static_cast<int>(base.size());
  bool finite = true;
  for (int k = 0; k < nnz; ++k) {
    const int row = k_row[k], col = k_col[k];
    double v = 0.0;
    if (row == m) {
      v = col == m ? (normalised ? -1.0 / w2 : -1.0) : c[col];
    } else {
      for (int p = pair_start[k]; p < pair_start[k + 1]; ++p) v += a[pair_a[p]] * a[pair_b[p]];
      if (row == col) {
        v += mu;
        diag_n[row] = v + w2 * c[row] * c[row];
      }
    }
    base[k] = v;
    finite = finite && std::isfinite(v);
  }
  factorization_valid = false;
  return finite;
}

bool Impl::factorize(const std::vector<char>& hold) {
  if (node_space) {
    for (int i = 0; i < m; ++i) {
      node_weight[i] = hold[i] ? 0.0 : 1.0 / mu;
      held_inverse[i] = hold[i] ? 1.0 / diag_n[i] : 0.0;
    }
    factored_held = hold;
    factorization_valid = factorize_node_space();
    return factorization_valid;
  }
  double* values = K.valuePtr();
  const int nnz = static_cast<int>(base.size());
  for (int k = 0; k < nnz; ++k) {
    const int row = k_row[k], col = k_col[k];
    const bool row_held = row < m && hold[row];
    const bool col_held = col < m && hold[col];
    if (row == col)
      values[k] = row_held ? diag_n[row] : base[k];
    else
      values[k] = row_held || col_held ? 0.0 : base[k];
  }
  factored_held = hold;
  factorization_valid = ldlt.factorize_values(K.valuePtr());
  return factorization_valid;
}

// out = N x.
void Impl::apply_normal(const SparseMatrix& A, const Eigen::VectorXd& x,
                                  Eigen::VectorXd& out) {
  a_step.noalias() = A * x;
  out.noalias() = A.transpose() * a_step;
  out += (w2 * c.dot(x)) * c + mu * x;
}

// out = N~ x, where N~ is N with the held rows/columns replaced by N_ii e_i.
void Impl::apply_modified(const Eigen::VectorXd& x, const SparseMatrix& A,
                                    Eigen::VectorXd& out) {
  for (int i = 0; i < m; ++i) masked[i] = factored_held[i] ? 0.0 : x[i];
  a_step.noalias() = A * masked;
  out.noalias() = A.transpose() * a_step;
  const double cx = w2 * c.dot(masked);
  for (int i = 0; i < m; ++i)
    out[i] = factored_held[i] ? diag_n[i] * x[i] : out[i] + cx * c[i] + mu * masked[i];
}

// x = K^{-1} [b; 0] (first m entries), then iterative refinement against the
// operator `apply` (out = M x) that K approximates: the near-null directions of
// A^T A, damped only by mu, would otherwise cost digits of accuracy.
template <class Apply>
bool Impl::refined_solve(const Eigen::VectorXd& b, Eigen::VectorXd& x, int refinements, Apply apply) {
  apply_preconditioner(b, x);
  const double b_norm = b.lpNorm<Eigen::Infinity>();
  double previous = kInf;
  for (int refinement = 0; refinement < refinements; ++refinement) {
    apply(x, op_out);
    lin_res = b - op_out;
    const double res_norm = lin_res.lpNorm<Eigen::Infinity>();
    if (!std::isfinite(res_norm)) return false;
    if (res_norm <= RefinementConstants::kRoundingFactor * kEps * b_norm ||
        res_norm > RefinementConstants::kSlowestContraction * previous)
      break;
    previous = res_norm;
    apply_preconditioner(lin_res, correction);
    x += correction;
  }
  return x.allFinite();
}

// Solves N~ x = b with the factorization of K, refined against N~ itself.
bool Impl::solve_modified(const SparseMatrix& A, const Eigen::VectorXd& b,
                                    Eigen::VectorXd& x) {
  return refined_solve(b, x, ProjectedNewtonConstants::kRefinements, [&](const Eigen::VectorXd& v, Eigen::VectorXd& out) { apply_modified(v, A, out); });
}

bool Impl::factorize_with_diagonal(const Eigen::VectorXd& extra) {
  if (node_space) {
    node_weight = (extra.array() + mu).inverse().matrix();
    held_inverse.setZero();
    factorization_valid = false;  // not the factorization of a held set
    return factorize_node_space();
  }
  double* values = K.valuePtr();
  const int nnz = static_cast<int>(base.size());
  for (int k = 0; k < nnz; ++k) {
    values[k] = base[k];
    if (k_row[k] == k_col[k] && k_row[k] < m) values[k] += extra[k_row[k]];
  }
  factorization_valid = false;  // not the factorization of a held set
  return ldlt.factorize_values(K.valuePtr());
}

// (N + diag(extra)) x = b with the current factorization, refined against N + diag(extra).
bool Impl::solve_with_diagonal(const SparseMatrix& A, const Eigen::VectorXd& extra,
                                         const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  return refined_solve(b, x, InteriorPointConstants::kRefinements, [&](const Eigen::VectorXd& v, Eigen::VectorXd& out) {
    apply_normal(A, v, out);
    out += extra.cwiseProduct(v);
  });
}

void Impl::residual(const SparseMatrix& A, const Eigen::VectorXd* fg,
                              const Eigen::VectorXd& x, Eigen::VectorXd& res) const {
  res.noalias() = A * x;
  if (fg) res += *fg;
}

void Impl::apply_preconditioner(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  if (node_space) {
    apply_node_space_inverse(b, x);
    return;
  }
  aug_rhs.head(m) = b;
  aug_rhs[m] = 0.0;
  aug_sol = ldlt.solve(aug_rhs);
  x = aug_sol.head(m);
}

void Impl::evaluate(const SolveState& st, const Eigen::VectorXd& x, double mu_term) {
  residual(*st.A, st.fg, x, r);
  g.noalias() = st.A->transpose() * r;
  const double e = c.dot(x) - target;
  g += (w2 * e) * c + mu_term * (x - center);
}

double Impl::regularised_objective(const SolveState& st, const Eigen::VectorXd& x) {
  evaluate(st, x, mu);
  const double e = c.dot(x) - target;
  return 0.5 * (r.squaredNorm() + w2 * e * e + mu * (x - center).squaredNorm());
}

double Impl::mu_free_objective(const SolveState& st, const Eigen::VectorXd& x) {
  evaluate(st, x, 0.0);
  const double e = c.dot(x) - target;
  return r.squaredNorm() + w2 * e * e;
}

double Impl::gradient_scale(const SolveState& st, const Eigen::VectorXd& x) const {
  return std::max({f0, x.lpNorm<Eigen::Infinity>(), st.fg_max});
}

double Impl::largest_node_norm(const Eigen::VectorXd& v) const {
  double largest = 0.0;
  for (int k = 0; 3 * k + 2 < rows; ++k) largest = std::max(largest, v.segment<3>(3 * k).norm());
  return largest;
}

double Impl::relative_residual(const SolveState& st, const Eigen::VectorXd& x) const {
  const double largest = largest_node_norm(r);
  if (largest == 0.0) return 0.0;
  const double scale = st.fg ? largest_node_norm(*st.fg) : x.lpNorm<Eigen::Infinity>();
  return scale > 0.0 ? largest / scale : kInf;
}

}  // namespace stress_qp_detail

using stress_qp_detail::kEps;
using stress_qp_detail::kInf;
using stress_qp_detail::SolveState;
using SparseMatrix = stress_qp_detail::SparseMatrix;

StressQp::StressQp(const Equilibrium& eq, const ForceScale& scale, StressQpOptions options)
    : eq_(eq), scale_(scale), options_(options), impl_(std::make_unique<Impl>()) {
  impl_->build(eq_.A(), scale_, options_);
}

StressQp::~StressQp() = default;

StressQpResult StressQp::solve() {
  Impl& q = *impl_;
  const int m = eq_.num_elements();
  Eigen::VectorXd start(m);
  const double f0 = q.m == m ? q.f0 : 1.0;
  for (int e = 0; e < m; ++e) {
    const double lo = q.m == m ? q.lower[e] : -kInf;
    const double hi = q.m == m ? q.upper[e] : kInf;
    start[e] = hi == kInf ? f0 : (lo == -kInf ? -f0 : 0.5 * (lo + hi));
  }
  return solve_from(start, false);
}

StressQpResult StressQp::solve(const Eigen::VectorXd& sigma0) { return solve_from(sigma0, true); }

void StressQp::set_shift(const Eigen::VectorXd& load, double target) {
  Impl& q = *impl_;
  q.load_shift = load;
  q.target_shift = std::isfinite(target) ? target : 0.0;
  q.target = q.scale_target + (q.normalised ? q.target_shift : 0.0);
}

StressQpResult StressQp::solve_from(const Eigen::VectorXd& sigma0, bool warm_start) {
  const SparseMatrix& A = eq_.A();
  Impl& q = *impl_;
  if (!q.pattern_matches(A)) q.build(A, scale_, options_);
  const int m = q.m;

  // Starting point: sigma0 projected; the cold start where it is unusable
  // (and then the solve is a cold one in every respect).
  const bool usable = sigma0.size() == m && sigma0.allFinite();
  SolveState st;
  st.A = &A;
  st.warm_start = warm_start && usable;
  for (int i = 0; i < m; ++i)
    q.s[i] = q.project(i, usable ? sigma0[i] : (q.upper[i] == kInf ? q.f0 : (q.lower[i] == -kInf ? -q.f0 : 0.0)));

  const Eigen::VectorXd& fg_full = eq_.gravity_load();
  st.fg = eq_.has_gravity() && fg_full.size() == q.rows ? &fg_full : nullptr;
  if (q.load_shift.size() == q.rows) {
    if (st.fg) q.shifted_load = *st.fg + q.load_shift;
    else q.shifted_load = q.load_shift;
    st.fg = &q.shifted_load;
  }
  st.fg_max = st.fg ? st.fg->lpNorm<Eigen::Infinity>() : 0.0;
  st.tolerance = std::max(options_.optimality_tolerance,
                          stress_qp_detail::ProjectedNewtonConstants::kRoundingFactor * kEps * std::sqrt(m + 1.0));
  // The regulariser's centre: the origin (the paper's smallest forces) or,
  // with options_.proximal and a usable warm start, the projected warm start.
  if (options_.proximal && st.warm_start) q.center = q.s;
  else q.center.setZero(m);

  st.ok = options_.IsValid() && q.refresh(A) && (st.fg == nullptr || std::isfinite(st.fg_max));
  if (st.ok) q.projected_newton(options_, st);
  // The polish runs also after an iteration cap: on a free set that is
  // nearly right it often reaches equilibrium, which the caller verifies.
  if (st.ok && !st.gave_up && options_.max_polish_steps > 0) q.polish(options_, st);
  if (options_.polish_to_optimum && st.polish_steps >= options_.max_polish_steps) st.hit_iteration_cap = true;
  return report(st);
}

// Without certify_optimum every KKT point counts; with it, an objective at
// rounding level needs no bound, and any other needs one near it.
bool StressQp::certified(SolveState& st, StressQpResult& result) {
  if (!options_.certify_optimum) return true;
  Impl& q = *impl_;
  const double rounding = stress_qp_detail::PolishConstants::kCgRoundingFactor * kEps * q.gradient_scale(st, q.s);
  if (result.objective <= rounding * rounding) {
    result.objective_lower_bound = result.objective;
    return true;
  }
  result.objective_lower_bound = q.objective_lower_bound(st);
  result.factorizations = st.factorizations;
  return result.objective_lower_bound >= stress_qp_detail::CertificateConstants::kCertifiedFraction * result.objective;
}

// The result, from a fresh evaluation of the returned forces. The KKT
// conditions are those of the objective without the mu term: a free force
// must have a zero gradient (the polish removes the mu bias there), a force at
// a bound a gradient pointing out of the box, allowing the mu term's pull
// mu |sigma_i - centre_i| there (a margin-sized force: negligible).
StressQpResult StressQp::report(SolveState& st) {
  Impl& q = *impl_;
  const int m = q.m;
  StressQpResult result;
  result.iterations = st.iterations;
  result.factorizations = st.factorizations;
  result.polish_steps = st.polish_steps;
  // s + (P(v) - s) can leave the box by rounding: the returned forces are projected.
  for (int i = 0; i < m; ++i) q.s[i] = q.project(i, std::isfinite(q.s[i]) ? q.s[i] : 0.0);
  result.sigma = q.s;
  q.evaluate(st, q.s, 0.0);
  const double e = q.c.dot(q.s) - q.target;
  result.normalisation_error = e;
  result.equilibrium_norm = q.r.norm();
  result.objective = q.r.squaredNorm() + q.w2 * e * e;
  result.max_node_residual = q.largest_node_norm(q.r);
  double kkt = 0.0;
  for (int i = 0; i < m; ++i) {
    const bool at_lower = q.s[i] <= q.lower[i], at_upper = q.s[i] >= q.upper[i];
    double violation = std::abs(q.g[i]);
    double allowance = 0.0;
    if (at_lower && at_upper) violation = 0.0;
    else if (at_lower) violation = std::max(0.0, -q.g[i]);
    else if (at_upper) violation = std::max(0.0, q.g[i]);
    if (at_lower || at_upper) {
      ++result.active_bounds;
      allowance = q.mu * std::abs(q.s[i] - q.center[i]);
    }
    kkt = std::max(kkt, violation - allowance);
  }
  result.kkt_error = std::max(0.0, kkt) / q.gradient_scale(st, q.s);
  if (!std::isfinite(result.kkt_error)) result.kkt_error = kInf;
  for (double* v : {&result.normalisation_error, &result.equilibrium_norm, &result.objective,
                    &result.max_node_residual})
    if (!std::isfinite(*v)) *v = kInf;

  // A zero-length (or non-finite) element has no direction: the forces are
  // the best for the remaining columns, but not a trustworthy answer.
  if (!st.ok || eq_.degenerate() || !std::isfinite(result.objective)) {
    result.status = StressQpStatus::NumericalFailure;
    result.message = eq_.degenerate() ? "a zero-length or non-finite element has no direction"
                                      : "a factorization failed or a value was not finite";
  } else if (st.gave_up) {
    result.status = StressQpStatus::IterationLimit;
    result.gave_up = true;
    result.message = "gave up after " + std::to_string(st.iterations) + " steps at relative residual " +
                     message_number(q.relative_residual(st, q.s)) + " (above " + message_number(options_.give_up_residual) + ")";
  } else if (result.kkt_error > st.tolerance) {
    result.status = st.hit_iteration_cap ? StressQpStatus::IterationLimit : StressQpStatus::Stalled;
    result.message = std::string(st.hit_iteration_cap ? "step cap reached (max_iterations " +
                                                            std::to_string(options_.max_iterations) +
                                                            ", max_polish_steps " +
                                                            std::to_string(options_.max_polish_steps) + ")"
                                                      : "no further progress") +
                     " before the KKT conditions were met (error " + message_number(result.kkt_error) +
                     ", tolerance " + message_number(st.tolerance) + ")";
  } else if (!certified(st, result)) {
    result.status = StressQpStatus::Uncertified;
    result.message = "KKT conditions met to " + message_number(result.kkt_error) +
                     ", but not certified: the objective's lower bound is " +
                     message_number(result.objective_lower_bound) + " against " + message_number(result.objective) +
                     " (an ill-conditioned free set: the optimum may be much lower)";
  } else {
    result.status = StressQpStatus::Optimal;
    result.message = "KKT conditions met to " + message_number(result.kkt_error) + " (tolerance " +
                     message_number(st.tolerance) + ")";
  }
  result.optimal = result.status == StressQpStatus::Optimal;
  return result;
}

}  // namespace tensegrity
