// The polish of the stress QP (kernels/stress_qp.hpp): on the final free set,
// the objective without the mu term is minimised by conjugate gradients
// preconditioned with the factorization of (N + mu I)_FF, so that the
// returned forces carry no mu bias and a tensegrity reaches a residual at
// rounding level even along near-null directions of A (which the mu term
// alone damps, and which a plain iterated-Tikhonov polish resolves only at
// the rate mu / (mu + lambda_min) per step).
#include <algorithm>
#include <cmath>

#include "kernels/stress_qp_impl.hpp"

namespace tensegrity {
namespace stress_qp_detail {

using C = PolishConstants;

namespace {

// out = (A^T A + w^2 c c^T)_FF x on the free set (held entries are zero).
void apply_free_normal(Impl& q, const SparseMatrix& A, const Eigen::VectorXd& x, Eigen::VectorXd& out) {
  for (int i = 0; i < q.m; ++i) q.masked[i] = q.held[i] ? 0.0 : x[i];
  q.a_step.noalias() = A * q.masked;
  out.noalias() = A.transpose() * q.a_step;
  out += (q.w2 * q.c.dot(q.masked)) * q.c;
  for (int i = 0; i < q.m; ++i)
    if (q.held[i]) out[i] = 0.0;
}

// Preconditioned CG on (A^T A + w^2 c c^T)_FF x = b; false on a non-finite value.
bool conjugate_gradients(Impl& q, const SparseMatrix& A, const Eigen::VectorXd& b, double stop,
                         Eigen::VectorXd& x) {
  x.setZero(q.m);
  q.cg_r = b;
  q.apply_preconditioner(q.cg_r, q.cg_z);
  q.cg_p = q.cg_z;
  double rz = q.cg_r.dot(q.cg_z);
  for (int k = 0; k < C::kMaxCgIterations && rz > 0.0; ++k) {
    if (q.cg_r.lpNorm<Eigen::Infinity>() <= stop) break;
    apply_free_normal(q, A, q.cg_p, q.cg_q);
    const double curvature = q.cg_p.dot(q.cg_q);
    if (!(curvature > 0.0)) break;  // a null direction of A_F: nothing more to gain
    const double alpha = rz / curvature;
    x += alpha * q.cg_p;
    q.cg_r -= alpha * q.cg_q;
    q.apply_preconditioner(q.cg_r, q.cg_z);
    const double rz_next = q.cg_r.dot(q.cg_z);
    q.cg_p = q.cg_z + (rz_next / rz) * q.cg_p;
    rz = rz_next;
  }
  return x.allFinite();
}

}  // namespace

// Without polish_to_optimum: on the final free set only, bounds met on the
// way join it, and the polish ends at slow progress (cheap, for the solves
// inside an iteration, whose geometry changes again at once).
void Impl::polish_free_set(const StressQpOptions& options, SolveState& st) {
  const SparseMatrix& A = *st.A;
  bool refactor = true;
  double current = mu_free_objective(st, s);
  for (int k = 0; k < options.max_polish_steps; ++k) {
    const double scale = gradient_scale(st, s);
    if (current <= std::pow(C::kCgRoundingFactor * kEps * scale, 2)) break;
    if (refactor) {
      for (int i = 0; i < m; ++i) held[i] = s[i] <= lower[i] || s[i] >= upper[i];
      if (!(factorization_valid && held == factored_held)) {
        ++st.factorizations;
        if (!factorize(held)) {
          st.ok = false;
          return;
        }
      }
      refactor = false;
    }
    for (int i = 0; i < m; ++i) rhs[i] = held[i] ? 0.0 : -g[i];
    if (!conjugate_gradients(*this, A, rhs, C::kCgRoundingFactor * kEps * scale, d)) break;
    // The step stops at the first bound it meets (which then joins the held set).
    double alpha = 1.0;
    for (int i = 0; i < m; ++i) {
      if (held[i]) continue;
      if (d[i] < 0.0 && s[i] + d[i] < lower[i]) alpha = std::min(alpha, (lower[i] - s[i]) / d[i]);
      if (d[i] > 0.0 && s[i] + d[i] > upper[i]) alpha = std::min(alpha, (upper[i] - s[i]) / d[i]);
    }
    trial = s;
    for (int i = 0; i < m; ++i)
      if (!held[i]) s[i] = project(i, s[i] + alpha * d[i]);
    // The step's exact change of the objective, 2 g.dx + |A dx|^2 + w^2 (c.dx)^2
    // (g: half the mu-free gradient, zero on held forces): where the residual
    // does not vanish, a difference of two objectives is lost in rounding.
    step = s - trial;
    for (int i = 0; i < m; ++i)
      if (held[i]) g[i] = 0.0;
    const double change = 2.0 * g.dot(step) + curvature(A, step);
    if (!(change < 0.0)) {  // rounding level reached: keep the better point
      s = trial;
      evaluate(st, s, 0.0);
      break;
    }
    ++st.polish_steps;
    const bool slow = -change < C::kSlowProgress * current;
    current = mu_free_objective(st, s);
    refactor = alpha < 1.0;
    if (slow && !refactor) break;
  }
}

void Impl::polish(const StressQpOptions& options, SolveState& st) {
  if (options.polish_to_optimum) polish_to_optimum(options, st);
  else polish_free_set(options, st);
}

// With polish_to_optimum: an active-set method in the manner of Lawson and Hanson's NNLS: a
// least-squares step on the free set; when it leaves the box, the step stops
// at the first bound, which joins the held set; when it stays inside, the
// free set is optimal and the held force whose gradient points furthest into
// the box is released. Held forces are never released before the free set's
// least-squares problem is solved, so the method does not cycle between a
// bound and its release (a step blocked at once by the force it just freed).
void Impl::polish_to_optimum(const StressQpOptions& options, SolveState& st) {
  const SparseMatrix& A = *st.A;
  double current = mu_free_objective(st, s);
  // Start from the forces at a bound whose gradient points out of the box.
  for (int i = 0; i < m; ++i) held[i] = (s[i] <= lower[i] && g[i] >= 0.0) || (s[i] >= upper[i] && g[i] <= 0.0);
  for (int k = 0; k < options.max_polish_steps; ++k) {
    const double scale = gradient_scale(st, s);
    if (current <= std::pow(C::kCgRoundingFactor * kEps * scale, 2)) break;
    if (!(factorization_valid && held == factored_held)) {
      ++st.factorizations;
      if (!factorize(held)) {
        st.ok = false;
        return;
      }
    }
    for (int i = 0; i < m; ++i) rhs[i] = held[i] ? 0.0 : -g[i];
    if (!conjugate_gradients(*this, A, rhs, C::kCgRoundingFactor * kEps * scale, d)) break;
    double alpha = 1.0;
    int blocking = -1;
    for (int i = 0; i < m; ++i) {
      if (held[i]) continue;
      const double to_bound = d[i] < 0.0 ? (lower[i] - s[i]) / d[i] : d[i] > 0.0 ? (upper[i] - s[i]) / d[i] : kInf;
      if (to_bound < alpha) {
        alpha = to_bound;
        blocking = i;
      }
    }
    trial = s;
    for (int i = 0; i < m; ++i)
      if (!held[i]) s[i] = project(i, s[i] + alpha * d[i]);
    // The blocking force lands on its bound exactly (s + alpha d may miss it by
    // rounding, and a force a hair inside would block the next step at once).
    if (blocking >= 0) s[blocking] = d[blocking] < 0.0 ? lower[blocking] : upper[blocking];
    // The step's exact change of the objective, 2 g.dx + |A dx|^2 + w^2 (c.dx)^2
    // (g: half the mu-free gradient, zero on held forces): where the residual
    // does not vanish, a difference of two objectives is lost in rounding.
    step = s - trial;
    for (int i = 0; i < m; ++i)
      if (held[i]) g[i] = 0.0;
    const double change = 2.0 * g.dot(step) + curvature(A, step);
    if (change > 0.0) {  // rounding level reached: keep the better point
      s = trial;
      evaluate(st, s, 0.0);
      break;
    }
    ++st.polish_steps;
    current = mu_free_objective(st, s);
    if (blocking >= 0) {
      held[blocking] = 1;
      continue;
    }
    // The free set's least-squares optimum: release the held force whose
    // gradient points furthest into the box, or stop when none does.
    const double release_threshold = 0.0;
    int release = -1;
    double worst = release_threshold;
    for (int i = 0; i < m; ++i) {
      if (!held[i]) continue;
      const double inward = s[i] <= lower[i] ? -g[i] : s[i] >= upper[i] ? g[i] : kInf;
      if (inward > worst) {
        worst = inward;
        release = i;
      }
    }
    if (release < 0) break;
    held[release] = 0;
  }
}

// Weak duality for min F(x) = |B x + b|^2 over the box (B = [A; w c^T]): for
// any y, F(x) >= 2 y^T (B x + b) - |y|^2 = F(x') + 2 (B^T y)^T (x - x') with
// y = B x' + b. At x' = s + d, d the unconstrained least-squares step on the
// free set, B^T y vanishes on the free set up to rounding and must point out
// of the box at every held bound. What rounding leaves of B^T y on the free
// set (and of a held bound's wrong sign within the tolerance) is charged at a
// force range of |x'_i| + scale per force: the bound holds for every x in the
// box within that range of x'. On a near-mechanism that charge, not F(x'),
// decides, which is what keeps a tiny gradient from passing for a proof.
double Impl::objective_lower_bound(SolveState& st) {
  const SparseMatrix& A = *st.A;
  for (int i = 0; i < m; ++i) held[i] = s[i] <= lower[i] || s[i] >= upper[i];
  if (!(factorization_valid && held == factored_held)) {
    ++st.factorizations;
    if (!factorize(held)) return -kInf;
  }
  evaluate(st, s, 0.0);
  const double scale = gradient_scale(st, s);
  for (int i = 0; i < m; ++i) rhs[i] = held[i] ? 0.0 : -g[i];
  if (!conjugate_gradients(*this, A, rhs, C::kCgRoundingFactor * kEps * scale, d)) return -kInf;
  trial = s;
  for (int i = 0; i < m; ++i)
    if (!held[i]) trial[i] += d[i];
  const double at_trial = mu_free_objective(st, trial);
  const double allowed = st.tolerance * scale;
  double charge = 0.0;
  bool dual_feasible = std::isfinite(at_trial);
  for (int i = 0; i < m && dual_feasible; ++i) {
    // The part of g_i whose sign the box does not absorb.
    double loose = std::abs(g[i]);
    if (held[i] && s[i] <= lower[i] && s[i] < upper[i]) loose = std::max(0.0, -g[i]);
    else if (held[i] && s[i] >= upper[i] && s[i] > lower[i]) loose = std::max(0.0, g[i]);
    else if (held[i]) loose = 0.0;  // a fixed force (lower == upper)
    if (held[i] && loose > allowed) dual_feasible = false;
    charge += loose * (std::abs(trial[i]) + scale);
  }
  evaluate(st, s, 0.0);  // r and g of the returned forces again
  return dual_feasible && std::isfinite(charge) ? at_trial - 2.0 * charge : -kInf;
}

}  // namespace stress_qp_detail
}  // namespace tensegrity
