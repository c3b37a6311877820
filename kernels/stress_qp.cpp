#include "kernels/stress_qp.hpp"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace tensegrity {

bool StressQpOptions::IsValid() const {
  return std::isfinite(mu) && mu > 0.0 && std::isfinite(normalisation_weight) &&
         normalisation_weight >= 0.0 && max_iterations >= 0 && max_polish_steps >= 0 &&
         std::isfinite(optimality_tolerance) && optimality_tolerance > 0.0;
}

namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = std::numeric_limits<double>::epsilon();
// Rounds of pinning forces whose Newton component leaves the box (one
// factorization each; see the projected-Newton loop).
constexpr int kPinRounds = 5;

}  // namespace

struct StressQp::Impl {
  // Problem data.
  int m = 0;      // elements (unknowns)
  int rows = 0;   // 3 n_free (equations)
  double mu = 0.0, w2 = 0.0, target = 0.0, f0 = 1.0;
  bool normalised = false;
  Eigen::VectorXd lower, upper, c;

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

  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt;
  bool factorization_valid = false;
  std::vector<char> held, factored_held;  // W of the current step / of the factorization

  // Work space, sized once per topology.
  Eigen::VectorXd center;
  // Interior-point work space.
  Eigen::VectorXd ip_h, ip_rd, ip_zl, ip_zu, ip_d, ip_rhs, ip_dx, ip_dx_aff, ip_dzl, ip_dzu;
  Eigen::VectorXd s, g, d, trial, step, rhs, lin_res, op_out, masked, best_s;
  Eigen::VectorXd aug_rhs, aug_sol;
  Eigen::VectorXd r, a_step;  // equation-sized

  void build(const SparseMatrix& A, const ForceScale& scale, const StressQpOptions& o);
  bool pattern_matches(const SparseMatrix& A) const;
  bool refresh(const SparseMatrix& A);
  bool factorize(const std::vector<char>& hold);
  bool factorize_with_diagonal(const Eigen::VectorXd& extra);
  bool solve_with_diagonal(const SparseMatrix& A, const Eigen::VectorXd& extra, const Eigen::VectorXd& b,
                           Eigen::VectorXd& x);
  int interior_point(const SparseMatrix& A, const Eigen::VectorXd* fg, const Eigen::VectorXd& center,
                     double scale, Eigen::VectorXd& x);
  void apply_normal(const SparseMatrix& A, const Eigen::VectorXd& x, Eigen::VectorXd& out);
  void apply_modified(const Eigen::VectorXd& x, const SparseMatrix& A, Eigen::VectorXd& out);
  bool solve_modified(const SparseMatrix& A, const Eigen::VectorXd& b, Eigen::VectorXd& x);
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
};

void StressQp::Impl::build(const SparseMatrix& A, const ForceScale& scale,
                           const StressQpOptions& o) {
  m = static_cast<int>(A.cols());
  rows = static_cast<int>(A.rows());
  mu = o.mu;
  normalised = scale.has_normalisation() && o.normalisation_weight > 0.0 &&
               scale.normalisation_row.size() == m;
  w2 = normalised ? o.normalisation_weight * o.normalisation_weight : 0.0;
  target = normalised ? scale.normalisation_target : 0.0;
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

  ldlt.analyzePattern(K);
  factorization_valid = false;
  held.assign(m, 0);
  factored_held.assign(m, 0);

  for (Eigen::VectorXd* v : {&s, &g, &d, &trial, &step, &rhs, &lin_res, &op_out, &masked, &best_s})
    v->setZero(m);
  aug_rhs.setZero(m + 1);
  aug_sol.setZero(m + 1);
  r.setZero(rows);
  a_step.setZero(rows);
}

bool StressQp::Impl::pattern_matches(const SparseMatrix& A) const {
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
bool StressQp::Impl::refresh(const SparseMatrix& A) {
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

bool StressQp::Impl::factorize(const std::vector<char>& hold) {
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
  ldlt.factorize(K);
  factored_held = hold;
  factorization_valid = ldlt.info() == Eigen::Success;
  return factorization_valid;
}

// out = N x.
void StressQp::Impl::apply_normal(const SparseMatrix& A, const Eigen::VectorXd& x,
                                  Eigen::VectorXd& out) {
  a_step.noalias() = A * x;
  out.noalias() = A.transpose() * a_step;
  out += (w2 * c.dot(x)) * c + mu * x;
}

// out = N~ x, where N~ is N with the held rows/columns replaced by N_ii e_i.
void StressQp::Impl::apply_modified(const Eigen::VectorXd& x, const SparseMatrix& A,
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
// A^T A, damped only by mu, would otherwise cost ~6 digits.
template <class Apply>
bool StressQp::Impl::refined_solve(const Eigen::VectorXd& b, Eigen::VectorXd& x, int refinements, Apply apply) {
  aug_rhs.head(m) = b;
  aug_rhs[m] = 0.0;
  aug_sol = ldlt.solve(aug_rhs);
  x = aug_sol.head(m);
  const double b_norm = b.lpNorm<Eigen::Infinity>();
  double previous = kInf;
  for (int refinement = 0; refinement < refinements; ++refinement) {
    apply(x, op_out);
    lin_res = b - op_out;
    const double res_norm = lin_res.lpNorm<Eigen::Infinity>();
    if (!std::isfinite(res_norm)) return false;
    if (res_norm <= 4.0 * kEps * b_norm || res_norm > 0.5 * previous) break;
    previous = res_norm;
    aug_rhs.head(m) = lin_res;
    aug_rhs[m] = 0.0;
    aug_sol = ldlt.solve(aug_rhs);
    x += aug_sol.head(m);
  }
  return x.allFinite();
}

// Solves N~ x = b with the factorization of K, refined against N~ itself.
bool StressQp::Impl::solve_modified(const SparseMatrix& A, const Eigen::VectorXd& b,
                                    Eigen::VectorXd& x) {
  return refined_solve(b, x, 4, [&](const Eigen::VectorXd& v, Eigen::VectorXd& out) { apply_modified(v, A, out); });
}

bool StressQp::Impl::factorize_with_diagonal(const Eigen::VectorXd& extra) {
  double* values = K.valuePtr();
  const int nnz = static_cast<int>(base.size());
  for (int k = 0; k < nnz; ++k) {
    values[k] = base[k];
    if (k_row[k] == k_col[k] && k_row[k] < m) values[k] += extra[k_row[k]];
  }
  ldlt.factorize(K);
  factorization_valid = false;  // not the factorization of a held set
  return ldlt.info() == Eigen::Success;
}

// (N + diag(extra)) x = b with the current factorization, refined against N + diag(extra).
bool StressQp::Impl::solve_with_diagonal(const SparseMatrix& A, const Eigen::VectorXd& extra,
                                         const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  return refined_solve(b, x, 3, [&](const Eigen::VectorXd& v, Eigen::VectorXd& out) {
    apply_normal(A, v, out);
    out += extra.cwiseProduct(v);
  });
}

// Mehrotra predictor-corrector interior-point method for the bound-
// constrained QP min 1/2 x'Nx + h'x, lower <= x <= upper, from a strictly
// interior point. Why: from a cold start on near-mechanisms (many forces end
// at a bound, A^T A nearly singular) the projected Newton iteration changes
// the active set a few forces at a time and needs hundreds of
// factorizations; the interior-point iteration needs some 15-40 whatever the
// number of active bounds, each a factorization of the same pattern. It
// returns a point close to the optimum, whose active set the projected
// Newton iteration then confirms in a few steps. Returns the number of
// factorizations (x is left at the last iterate).
int StressQp::Impl::interior_point(const SparseMatrix& A, const Eigen::VectorXd* fg,
                                   const Eigen::VectorXd& centre, double scale, Eigen::VectorXd& x) {
  for (Eigen::VectorXd* v : {&ip_rd, &ip_d, &ip_rhs, &ip_dx, &ip_dx_aff}) v->resize(m);
  // h = A^T f_g - w^2 t c - mu centre.
  ip_h.setZero(m);
  if (fg) ip_h.noalias() = A.transpose() * (*fg);
  ip_h -= (w2 * target) * c + mu * centre;
  // Strictly interior start: one F0-scale away from every finite bound.
  const double gap = std::max(scale, 1e-300);
  for (int i = 0; i < m; ++i) {
    const bool lo = lower[i] > -kInf, hi = upper[i] < kInf;
    if (lo && hi) x[i] = 0.5 * (lower[i] + upper[i]);
    else if (lo) x[i] = std::max(x[i], lower[i] + gap);
    else if (hi) x[i] = std::min(x[i], upper[i] - gap);
  }
  ip_zl.setZero(m);
  ip_zu.setZero(m);
  int bounds = 0;
  for (int i = 0; i < m; ++i) {
    if (lower[i] > -kInf && x[i] > lower[i]) { ip_zl[i] = gap; ++bounds; }
    if (upper[i] < kInf && x[i] < upper[i]) { ip_zu[i] = gap; ++bounds; }
  }
  if (bounds == 0) return 0;
  auto s_lower = [&](int i) { return x[i] - lower[i]; };
  auto s_upper = [&](int i) { return upper[i] - x[i]; };
  auto complementarity = [&]() {
    double sum = 0.0;
    for (int i = 0; i < m; ++i) {
      if (ip_zl[i] > 0.0) sum += s_lower(i) * ip_zl[i];
      if (ip_zu[i] > 0.0) sum += s_upper(i) * ip_zu[i];
    }
    return sum / bounds;
  };
  // Largest step in (0, 1] keeping slacks and multipliers positive (fraction to the boundary).
  auto step_length = [&](const Eigen::VectorXd& dx, const Eigen::VectorXd& dzl, const Eigen::VectorXd& dzu,
                         double fraction) {
    double alpha = 1.0;
    for (int i = 0; i < m; ++i) {
      if (ip_zl[i] > 0.0) {
        if (dx[i] < 0.0) alpha = std::min(alpha, -fraction * s_lower(i) / dx[i]);
        if (dzl[i] < 0.0) alpha = std::min(alpha, -fraction * ip_zl[i] / dzl[i]);
      }
      if (ip_zu[i] > 0.0) {
        if (dx[i] > 0.0) alpha = std::min(alpha, fraction * s_upper(i) / dx[i]);
        if (dzu[i] < 0.0) alpha = std::min(alpha, -fraction * ip_zu[i] / dzu[i]);
      }
    }
    return alpha;
  };
  ip_dzl.setZero(m);
  ip_dzu.setZero(m);
  int factorizations = 0;
  for (int iteration = 0; iteration < 60; ++iteration) {
    // Dual residual r_d = N x + h - z_l + z_u.
    apply_normal(A, x, ip_rd);
    ip_rd += ip_h - ip_zl + ip_zu;
    const double gap_now = complementarity();
    if (!std::isfinite(gap_now) || !ip_rd.allFinite()) break;
    // The crossover below needs the slack of an active bound under its
    // multiplier. On near-mechanisms with gravity the multipliers are tiny
    // (1e-9 .. 1e-6 of the scale; the objective's gradient is small at a
    // small residual), so a mean complementarity of 1e-12 scale^2 left every
    // slack above its multiplier, nothing was snapped, and projected Newton
    // found the 115 active bounds of a perturbed gravity tower one per
    // iteration (450 iterations, 1200 factorizations cold; warm solves hit
    // the iteration cap). At 1e-20 scale^2 the crossover snaps them all,
    // for 2-5 more factorizations here: 21 iterations, 66 factorizations.
    if (ip_rd.lpNorm<Eigen::Infinity>() <= 1e-10 * scale && gap_now <= 1e-20 * scale * scale) break;
    for (int i = 0; i < m; ++i)
      ip_d[i] = (ip_zl[i] > 0.0 ? ip_zl[i] / s_lower(i) : 0.0) + (ip_zu[i] > 0.0 ? ip_zu[i] / s_upper(i) : 0.0);
    ++factorizations;
    if (!factorize_with_diagonal(ip_d)) break;
    // Predictor (tau = 0): (N + D) dx = -(N x + h).
    ip_rhs = -ip_rd - ip_zl + ip_zu;
    if (!solve_with_diagonal(A, ip_d, ip_rhs, ip_dx_aff)) break;
    for (int i = 0; i < m; ++i) {
      ip_dzl[i] = ip_zl[i] > 0.0 ? -ip_zl[i] - ip_zl[i] / s_lower(i) * ip_dx_aff[i] : 0.0;
      ip_dzu[i] = ip_zu[i] > 0.0 ? -ip_zu[i] + ip_zu[i] / s_upper(i) * ip_dx_aff[i] : 0.0;
    }
    const double alpha_aff = step_length(ip_dx_aff, ip_dzl, ip_dzu, 1.0);
    double gap_aff = 0.0;
    for (int i = 0; i < m; ++i) {
      if (ip_zl[i] > 0.0) gap_aff += (s_lower(i) + alpha_aff * ip_dx_aff[i]) * (ip_zl[i] + alpha_aff * ip_dzl[i]);
      if (ip_zu[i] > 0.0) gap_aff += (s_upper(i) - alpha_aff * ip_dx_aff[i]) * (ip_zu[i] + alpha_aff * ip_dzu[i]);
    }
    gap_aff /= bounds;
    const double tau = std::pow(std::max(0.0, gap_aff / gap_now), 3) * gap_now;
    // Corrector with Mehrotra's second-order term: per bound, tau' = tau - ds_aff dz_aff.
    ip_rhs = -ip_rd;
    for (int i = 0; i < m; ++i) {
      if (ip_zl[i] > 0.0) {
        const double t = tau - ip_dx_aff[i] * ip_dzl[i];
        ip_rhs[i] += t / s_lower(i) - ip_zl[i];
      }
      if (ip_zu[i] > 0.0) {
        const double t = tau + ip_dx_aff[i] * ip_dzu[i];  // ds_u = -dx
        ip_rhs[i] -= t / s_upper(i) - ip_zu[i];
      }
    }
    if (!solve_with_diagonal(A, ip_d, ip_rhs, ip_dx)) break;
    for (int i = 0; i < m; ++i) {
      if (ip_zl[i] > 0.0) {
        const double t = tau - ip_dx_aff[i] * ip_dzl[i];
        ip_dzl[i] = (t - s_lower(i) * ip_zl[i] - ip_zl[i] * ip_dx[i]) / s_lower(i);
      }
      if (ip_zu[i] > 0.0) {
        const double t = tau + ip_dx_aff[i] * ip_dzu[i];
        ip_dzu[i] = (t - s_upper(i) * ip_zu[i] + ip_zu[i] * ip_dx[i]) / s_upper(i);
      }
    }
    const double alpha = step_length(ip_dx, ip_dzl, ip_dzu, 0.995);
    if (!(alpha > 0.0)) break;
    x += alpha * ip_dx;
    for (int i = 0; i < m; ++i) {
      if (ip_zl[i] > 0.0) ip_zl[i] = std::max(ip_zl[i] + alpha * ip_dzl[i], 1e-300);
      if (ip_zu[i] > 0.0) ip_zu[i] = std::max(ip_zu[i] + alpha * ip_dzu[i], 1e-300);
    }
  }
  // Crossover: a bound whose slack is below its multiplier is taken as
  // active (strict complementarity), so the projected Newton iteration
  // starts from the predicted active set instead of re-discovering it.
  for (int i = 0; i < m; ++i) {
    if (ip_zl[i] > 0.0 && s_lower(i) < ip_zl[i]) x[i] = lower[i];
    if (ip_zu[i] > 0.0 && s_upper(i) < ip_zu[i]) x[i] = upper[i];
  }
  return factorizations;
}

void StressQp::Impl::residual(const SparseMatrix& A, const Eigen::VectorXd* fg,
                              const Eigen::VectorXd& x, Eigen::VectorXd& res) const {
  res.noalias() = A * x;
  if (fg) res += *fg;
}

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

StressQpResult StressQp::solve_from(const Eigen::VectorXd& sigma0, bool warm_start) {
  const SparseMatrix& A = eq_.A();
  Impl& q = *impl_;
  StressQpResult result;
  if (!q.pattern_matches(A)) q.build(A, scale_, options_);
  const int m = q.m;

  // Starting point: sigma0 projected; the cold start where it is unusable
  // (and then the solve is a cold one in every respect).
  const bool usable = sigma0.size() == m && sigma0.allFinite();
  warm_start = warm_start && usable;
  if (usable) {
    for (int i = 0; i < m; ++i) q.s[i] = q.project(i, sigma0[i]);
  } else {
    for (int i = 0; i < m; ++i)
      q.s[i] = q.project(i, q.upper[i] == kInf ? q.f0 : (q.lower[i] == -kInf ? -q.f0 : 0.0));
  }

  const Eigen::VectorXd& fg_full = eq_.gravity_load();
  const Eigen::VectorXd* fg =
      eq_.has_gravity() && fg_full.size() == q.rows ? &fg_full : nullptr;
  const double fg_max = fg ? fg->lpNorm<Eigen::Infinity>() : 0.0;

  const double tol = std::max(options_.optimality_tolerance, 32.0 * kEps * std::sqrt(m + 1.0));
  auto gradient_scale = [&](const Eigen::VectorXd& x) {
    return std::max({q.f0, x.lpNorm<Eigen::Infinity>(), fg_max});
  };
  // The regulariser's centre: the origin (the paper's smallest forces) or,
  // with options_.proximal and a usable warm start, the projected warm start;
  // an interior-point phase moves it (below).
  if (options_.proximal && warm_start) q.center = q.s;
  else q.center.setZero(m);
  // r = A s + f_g and g = A^T r + w^2 c (c^T s - t) + mu_term (s - centre).
  auto evaluate = [&](const Eigen::VectorXd& x, double mu_term) {
    q.residual(A, fg, x, q.r);
    q.g.noalias() = A.transpose() * q.r;
    const double e = q.c.dot(x) - q.target;
    q.g += (q.w2 * e) * q.c + mu_term * (x - q.center);
  };

  // Half the regularised objective at x; leaves q.r and q.g evaluated there.
  auto regularised_objective = [&](const Eigen::VectorXd& x) {
    evaluate(x, q.mu);
    return 0.5 * (q.r.squaredNorm() + q.w2 * std::pow(q.c.dot(x) - q.target, 2) +
                  q.mu * (x - q.center).squaredNorm());
  };

  bool ok = options_.IsValid() && q.refresh(A) && (fg == nullptr || std::isfinite(fg_max));
  bool settled = false;
  bool last_step_exact = false;

  // Projected Newton on the regularised objective. A few non-monotone full
  // steps are allowed (as in a primal-dual active-set method: the projection
  // of the subproblem's minimiser predicts the new active set at once, even
  // when that point is worse), safeguarded by a return to the best point.
  double best_objective = kInf;
  // Only a cold start takes non-monotone steps (also after its interior-point
  // phase): from a warm start the optimum is near, and on degenerate
  // scenes the projection of a full step predicts its active set badly (on
  // the perturbed 80/500 towers the first such step raised the objective from
  // 2e-5 to 6e3, and the solve never returned below its warm start:
  // 80-280 factorizations for nothing).
  int nonmonotone_left = warm_start ? 0 : 8;
  bool interior_point_used = false, stuck = false;
  for (int iteration = 0; ok; ++iteration) {
    if (!interior_point_used && options_.interior_point_after >= 0 &&
        (iteration == options_.interior_point_after || stuck)) {
      // The active set is changing a few forces at a time (a near-mechanism
      // with many forces at a bound): an interior-point phase finds the
      // neighbourhood of the optimum in some 15-40 factorizations whatever
      // the number of bounds involved; the projected Newton steps then
      // confirm its active set. Its point already holds the small forces the
      // mu term asks for (to the accuracy that mu's weak curvature allows,
      // ~1e-4 relative), so mu is centred on it from here on: the pull
      // towards the origin would otherwise trade residual for norm again.
      interior_point_used = true;
      result.factorizations += q.interior_point(A, fg, q.center, std::max(q.f0, fg_max), q.s);
      for (int i = 0; i < m; ++i) q.s[i] = q.project(i, std::isfinite(q.s[i]) ? q.s[i] : 0.0);
      q.center = q.s;
      best_objective = kInf;
      nonmonotone_left = warm_start ? 0 : 8;
      last_step_exact = false;
    }
    const double objective = regularised_objective(q.s);
    const bool record = objective < best_objective;
    if (record) {
      best_objective = objective;
      q.best_s = q.s;
    } else if (nonmonotone_left == 0 && std::isfinite(best_objective)) {
      q.s = q.best_s;  // budget spent: continue monotonically from the best point
      evaluate(q.s, q.mu);
      nonmonotone_left = -1;
      last_step_exact = false;
    }
    double pg = 0.0;
    for (int i = 0; i < m; ++i) pg = std::max(pg, std::abs(q.s[i] - q.project(i, q.s[i] - q.g[i])));
    if (!std::isfinite(pg)) { ok = false; break; }
    if (pg <= tol * gradient_scale(q.s)) { settled = true; break; }
    // Already an equilibrium to rounding accuracy (a warm start from a
    // solution): the mu term would only trade that residual for a smaller
    // norm, and on near-mechanisms (tiny singular values of A) it costs many
    // active-set changes and digits of residual that the polish cannot win back.
    if (q.r.lpNorm<Eigen::Infinity>() <= tol * gradient_scale(q.s) &&
        std::sqrt(q.w2) * std::abs(q.c.dot(q.s) - q.target) <= tol * gradient_scale(q.s)) {
      settled = true;
      break;
    }

    // Held set W: forces at a bound with the gradient pushing out. (Bertsekas'
    // epsilon-enlarged set, which also holds forces merely near a bound,
    // converged linearly on degenerate scenes: it keeps nudging forces whose
    // optimum lies just inside the box. The truncated-step candidate below
    // gives the progress guarantee instead.)
    for (int i = 0; i < m; ++i) {
      q.held[i] = (q.s[i] <= q.lower[i] && q.g[i] > 0.0) || (q.s[i] >= q.upper[i] && q.g[i] < 0.0);
    }
    // A warm start's first step keeps every force at a bound there: the
    // previous optimum's active set (which the projected warm start
    // reproduces) is nearly always still the active set after a small change
    // of geometry, but the gradient at the old forces points inwards at many
    // of its bounds, and freeing them costs a pinning round (a factorization)
    // each (on the perturbed 80/500 gravity tower: 5-6 factorizations per
    // warm solve, of which ~1-2 remain). The next iteration frees what the
    // gradient at the subproblem's minimiser says should be free.
    if (iteration == 0 && warm_start)
      for (int i = 0; i < m; ++i) q.held[i] = q.s[i] <= q.lower[i] || q.s[i] >= q.upper[i];
    if (last_step_exact && q.factorization_valid && q.held == q.factored_held) {
      settled = true;
      break;
    }
    if (iteration >= options_.max_iterations) break;
    if (!q.factorization_valid || q.held != q.factored_held) {
      ++result.factorizations;
      if (!q.factorize(q.held)) { ok = false; break; }
    }
    q.rhs = -q.g;
    if (!q.solve_modified(A, q.rhs, q.d)) { ok = false; break; }
    // A force at a bound whose gradient points into the box is free, but the
    // coupled Newton step can push it out: the projection then clips it and
    // the step is no longer a Newton step for the others, so the iteration
    // jams (on the 80/500 towers, warm solves crept along at a fixed
    // projected gradient until the iteration cap: 60-100 factorizations per
    // solve). Pin such forces at their bound and solve again on the smaller
    // free set; at the pinned subproblem's minimiser the Newton step of at
    // least one pinned force points inwards (S^-1 is positive definite), so
    // the forces that should be free are freed again.
    for (int round = 0; round < kPinRounds; ++round) {
      bool changed = false;
      for (int i = 0; i < m; ++i) {
        if (q.held[i]) continue;
        if ((q.s[i] <= q.lower[i] && q.d[i] < 0.0) || (q.s[i] >= q.upper[i] && q.d[i] > 0.0)) {
          q.held[i] = 1;
          changed = true;
        }
      }
      if (!changed) break;
      ++result.factorizations;
      if (!q.factorize(q.held) || !q.solve_modified(A, q.rhs, q.d)) {
        ok = false;
        break;
      }
    }
    if (!ok) break;
    // A held row of K gives a scaled gradient step out of the box, which the
    // projection would undo; as a zero it no longer blocks the truncated step
    // below at length 0 (which made that candidate useless whenever a force
    // was held).
    for (int i = 0; i < m; ++i)
      if (q.held[i]) q.d[i] = 0.0;

    // Candidate steps, judged by the exact decrease of the quadratic
    // (-g.dx - dx.N dx / 2, accurate near a non-zero minimum, unlike a
    // difference of objectives):
    //  - the projected Newton step P(s + d) (the usual case);
    //  - Bertsekas' Armijo backtracking along the projection arc;
    //  - d truncated at the first bound it meets (a guaranteed decrease that
    //    makes the blocking bound active, as in a primal active-set method).
    // The largest decrease wins, so a poor projection (many bounds crossed
    // at once from a warm start) cannot stall the iteration.
    auto decrease_of = [&](const Eigen::VectorXd& step) {
      return -q.g.dot(step) - 0.5 * (q.curvature(A, step) + q.mu * step.squaredNorm());
    };
    auto projected_step = [&](double alpha) {
      for (int i = 0; i < m; ++i) q.step[i] = q.project(i, q.s[i] + alpha * q.d[i]) - q.s[i];
      return -q.g.dot(q.step);  // first-order decrease, for the Armijo test
    };
    double best = 0.0;
    bool full_step = false;
    auto consider = [&](double decrease) {
      if (decrease > best) {
        best = decrease;
        q.trial = q.s + q.step;
        return true;
      }
      return false;
    };
    const double predicted_full = projected_step(1.0);
    const double decrease_full = decrease_of(q.step);
    full_step = consider(decrease_full);
    bool clipped = false;  // did the projection change a free component of s + d?
    for (int i = 0; i < m && !clipped; ++i)
      clipped = !q.held[i] && q.project(i, q.s[i] + q.d[i]) != q.s[i] + q.d[i];
    const bool armijo_full = decrease_full >= 1e-4 * predicted_full && decrease_full > 0.0;
    // Only from a new best point, which rules out cycling between two sets.
    if (!armijo_full && nonmonotone_left > 0 && record) {
      --nonmonotone_left;
      q.trial = q.s + q.step;
      full_step = true;
      best = kInf;  // taken regardless of the decrease
    } else if (!armijo_full) {
      double alpha_max = 1.0;
      for (int i = 0; i < m; ++i) {
        if (q.d[i] < 0.0) alpha_max = std::min(alpha_max, (q.lower[i] - q.s[i]) / q.d[i]);
        if (q.d[i] > 0.0) alpha_max = std::min(alpha_max, (q.upper[i] - q.s[i]) / q.d[i]);
      }
      if (alpha_max > 0.0) {
        projected_step(alpha_max);  // exact up to the blocking bound, which it lands on
        if (consider(decrease_of(q.step))) full_step = false;
      }
      double alpha = 0.5;
      for (int trial = 0; trial < 40; ++trial, alpha *= 0.5) {
        const double predicted = projected_step(alpha);
        if (q.step.lpNorm<Eigen::Infinity>() == 0.0) break;
        const double decrease = decrease_of(q.step);
        if (decrease > 0.0 && decrease >= 1e-4 * predicted) {
          if (consider(decrease)) full_step = false;
          break;
        }
      }
    }
    if (!(best > 0.0)) {
      // The Newton direction can still fail to descend along the projection
      // arc (pinning ran out of rounds with a free force at its bound whose
      // Newton component points out, or rounding). The projected diagonally
      // scaled gradient always descends unless sigma is stationary:
      // backtrack along it instead.
      double alpha = 1.0;
      for (int trial = 0; trial < 60; ++trial, alpha *= 0.5) {
        for (int i = 0; i < m; ++i)
          q.step[i] = q.project(i, q.s[i] - alpha * q.g[i] / q.diag_n[i]) - q.s[i];
        if (q.step.lpNorm<Eigen::Infinity>() == 0.0) break;
        const double predicted = -q.g.dot(q.step);
        const double decrease = decrease_of(q.step);
        if (decrease > 0.0 && decrease >= 1e-4 * predicted) {
          consider(decrease);
          break;
        }
      }
      full_step = false;
    }
    if (!(best > 0.0)) {  // no progress is possible at rounding level
      if (interior_point_used) break;
      stuck = true;  // unless the interior-point phase finds a better neighbourhood
      continue;
    }
    // An unclipped full Newton step (held forces take none, so they stay at
    // their bound) solved the subproblem of this held set exactly: if the
    // next gradient holds the same set, the active set has settled.
    last_step_exact = full_step && !clipped;
    q.s = q.trial;
    ++result.iterations;
  }

  // An unsettled solve (iteration cap) returns the best point visited since
  // the last change of the centre, not its last one, which a non-monotone
  // step may have left worse.
  if (ok && !settled && std::isfinite(best_objective) && q.best_s.size() == m &&
      best_objective < regularised_objective(q.s))
    q.s = q.best_s;

  // Polish on the final free set (the forces not at a bound): iterated
  // Tikhonov steps remove the mu bias from the residual.
  if (ok && settled && options_.max_polish_steps > 0) {
    for (int i = 0; i < m; ++i) q.held[i] = q.s[i] <= q.lower[i] || q.s[i] >= q.upper[i];
    bool factored = q.factorization_valid && q.held == q.factored_held;
    if (!factored) {
      ++result.factorizations;
      factored = q.factorize(q.held);
    }
    if (factored) {
      // Progress is measured by the objective without the mu term (what the
      // polish exists to reduce); the free gradient need not fall monotonically.
      auto residual_objective = [&]() {
        evaluate(q.s, 0.0);
        const double e = q.c.dot(q.s) - q.target;
        return q.r.squaredNorm() + q.w2 * e * e;
      };
      double current = residual_objective();
      const double floor = std::pow(4.0 * kEps * gradient_scale(q.s), 2);
      for (int step = 0; step < options_.max_polish_steps && current > floor; ++step) {
        for (int i = 0; i < m; ++i)
          if (q.held[i]) q.g[i] = 0.0;
        q.rhs = -q.g;
        if (!q.solve_modified(A, q.rhs, q.d)) break;
        q.trial = q.s;
        for (int i = 0; i < m; ++i)
          if (!q.held[i]) q.s[i] = q.project(i, q.s[i] + q.d[i]);
        // The step's exact change of the objective, 2 g.dx + |A dx|^2 +
        // w^2 (c.dx)^2 (g: half the mu-free gradient, zero on held forces):
        // where the residual does not vanish, the difference of two
        // objectives is lost in their rounding and a step that removes the
        // mu bias (~mu |sigma| / lambda_min) would be judged no better.
        q.step = q.s - q.trial;
        const double change = 2.0 * q.g.dot(q.step) + q.curvature(A, q.step);
        if (!(change < 0.0)) {  // rounding level reached: keep the better point
          q.s = q.trial;
          break;
        }
        ++result.polish_steps;
        const bool slow = -change < 0.01 * current;
        current = residual_objective();
        if (slow) break;
      }
    } else {
      ok = false;
    }
  }

  // Report, from a fresh evaluation of the returned forces.
  for (int i = 0; i < m; ++i)
    if (!std::isfinite(q.s[i])) q.s[i] = q.project(i, 0.0);
  result.sigma = q.s;
  evaluate(q.s, 0.0);
  const double e = q.c.dot(q.s) - q.target;
  result.normalisation_error = e;
  result.equilibrium_norm = q.r.norm();
  result.objective = q.r.squaredNorm() + q.w2 * e * e;
  double max_node = 0.0;
  for (int k = 0; 3 * k + 2 < q.rows; ++k) max_node = std::max(max_node, q.r.segment<3>(3 * k).norm());
  result.max_node_residual = max_node;
  double kkt = 0.0;
  for (int i = 0; i < m; ++i) {
    const double allowance = q.mu * std::abs(q.s[i] - q.center[i]);
    const bool at_lower = q.s[i] <= q.lower[i], at_upper = q.s[i] >= q.upper[i];
    double violation = std::abs(q.g[i]);
    if (at_lower && at_upper) violation = 0.0;
    else if (at_lower) violation = std::max(0.0, -q.g[i]);
    else if (at_upper) violation = std::max(0.0, q.g[i]);
    if (at_lower || at_upper) ++result.active_bounds;
    kkt = std::max(kkt, violation - allowance);
  }
  result.kkt_error = std::max(0.0, kkt) / gradient_scale(q.s);
  if (!std::isfinite(result.kkt_error)) result.kkt_error = kInf;
  for (double* v : {&result.normalisation_error, &result.equilibrium_norm, &result.objective,
                    &result.max_node_residual})
    if (!std::isfinite(*v)) *v = kInf;
  // A zero-length (or non-finite) element has no direction: the forces are
  // the best for the remaining columns, but not a trustworthy answer.
  result.optimal = ok && !eq_.degenerate() && result.kkt_error <= tol;
  return result;
}

}  // namespace tensegrity
