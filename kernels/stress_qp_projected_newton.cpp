// The projected-Newton phase of the stress QP (kernels/stress_qp.hpp), with
// its interior-point fallback.
#include <algorithm>
#include <cmath>

#include "kernels/stress_qp_impl.hpp"

namespace tensegrity {
namespace stress_qp_detail {

using C = ProjectedNewtonConstants;

void Impl::projected_newton(const StressQpOptions& options, SolveState& st) {
  // Only a cold start takes non-monotone steps (also after its interior-point
  // phase): from a warm start the optimum is near, and on degenerate scenes
  // the projection of a full step predicts its active set badly.
  st.nonmonotone_left = st.warm_start ? 0 : C::kNonmonotoneSteps;
  // The best objective at the last step that lowered it by more than
  // kStalledImprovement past the interior-point phase, and that step.
  double progress_objective = kInf;
  int progress_step = 0;
  for (int iteration = 0; st.ok; ++iteration) {
    if (!st.interior_point_used && options.interior_point_after >= 0 &&
        (iteration == options.interior_point_after || st.stuck)) {
      // The active set is changing a few forces at a time (a near-mechanism
      // with many forces at a bound): an interior-point phase finds the
      // optimum's neighbourhood whatever the number of bounds involved, and
      // projected Newton confirms its active set. Its point already holds the
      // small forces the mu term asks for, so mu is centred on it from here
      // on (the pull towards the origin would trade residual for norm again).
      st.interior_point_used = true;
      const double give_up_residual = options.end_interior_point_when_settled ? options.give_up_residual : 0.0;
      st.factorizations += interior_point(st, center, std::max(f0, st.fg_max), give_up_residual, s);
      for (int i = 0; i < m; ++i) s[i] = project(i, std::isfinite(s[i]) ? s[i] : 0.0);
      center = s;
      st.best_objective = kInf;
      st.nonmonotone_left = st.warm_start ? 0 : C::kNonmonotoneSteps;
      st.last_step_exact = false;
      st.stuck = false;
      progress_objective = kInf;
      progress_step = iteration;
    }
    const double objective = regularised_objective(st, s);
    const bool record = objective < st.best_objective;
    if (record) {
      st.best_objective = objective;
      best_s = s;
    } else if (st.nonmonotone_left == 0 && std::isfinite(st.best_objective)) {
      s = best_s;  // budget spent: continue monotonically from the best point
      evaluate(st, s, mu);
      st.nonmonotone_left = -1;
      st.last_step_exact = false;
    }
    double pg = 0.0;
    for (int i = 0; i < m; ++i) pg = std::max(pg, std::abs(s[i] - project(i, s[i] - g[i])));
    if (!std::isfinite(pg)) {
      st.ok = false;
      break;
    }
    const double tol = st.tolerance * gradient_scale(st, s);
    if (pg <= tol) {
      st.settled = true;
      break;
    }
    // Already an equilibrium to rounding accuracy (a warm start from a
    // solution): the mu term would only trade that residual for a smaller norm.
    if (r.lpNorm<Eigen::Infinity>() <= tol && std::sqrt(w2) * std::abs(c.dot(s) - target) <= tol) {
      st.settled = true;
      break;
    }

    // Held set W: forces at a bound with the gradient pushing out (not
    // Bertsekas' epsilon-enlarged set, which keeps nudging forces whose
    // optimum lies just inside the box; the truncated-step candidate gives
    // the progress guarantee instead).
    for (int i = 0; i < m; ++i)
      held[i] = (s[i] <= lower[i] && g[i] > 0.0) || (s[i] >= upper[i] && g[i] < 0.0);
    // A warm start's first step holds every force at a bound: the previous
    // active set is nearly always still right after a small change of
    // geometry, and freeing inward-pointing bounds costs a pinning round each.
    if (iteration == 0 && st.warm_start)
      for (int i = 0; i < m; ++i) held[i] = s[i] <= lower[i] || s[i] >= upper[i];
    if (st.last_step_exact && factorization_valid && held == factored_held) {
      st.settled = true;
      break;
    }
    if (options.end_when_stalled_after >= 0 && (st.interior_point_used || options.interior_point_after < 0)) {
      if (st.best_objective < (1.0 - C::kStalledImprovement) * progress_objective) {
        progress_objective = st.best_objective;
        progress_step = iteration;
      } else if (iteration - progress_step >= options.end_when_stalled_after) {
        break;  // unsettled: Stalled, from the best point visited
      }
    }
    if (iteration >= options.max_iterations) {
      st.hit_iteration_cap = true;
      break;
    }
    if (iteration == options.give_up_after) {
      // Judged at the forces a give-up returns: the best visited.
      const bool best_elsewhere = !record && std::isfinite(st.best_objective) && best_s.size() == m;
      if (best_elsewhere) evaluate(st, best_s, mu);
      const double residual = relative_residual(st, best_elsewhere ? best_s : s);
      if (residual > options.give_up_residual) {
        if (best_elsewhere) s = best_s;
        st.gave_up = true;
        break;
      }
      if (best_elsewhere) evaluate(st, s, mu);
    }
    if (!projected_newton_step(st, record)) {
      if (st.interior_point_used) break;  // no progress is possible at rounding level
      st.stuck = true;  // unless the interior-point phase finds a better neighbourhood
      if (options.interior_point_after < 0) break;
      continue;
    }
    ++st.iterations;
  }

  // An unsettled solve returns the best point visited since the last change
  // of the centre, not its last one, which a non-monotone step may have left worse.
  if (st.ok && !st.settled && std::isfinite(st.best_objective) && best_s.size() == m &&
      st.best_objective < regularised_objective(st, s))
    s = best_s;
}

bool Impl::projected_newton_step(SolveState& st, bool record) {
  const SparseMatrix& A = *st.A;
  if (!factorization_valid || held != factored_held) {
    ++st.factorizations;
    if (!factorize(held)) return st.ok = false;
  }
  rhs = -g;
  if (!solve_modified(A, rhs, d)) return st.ok = false;
  // A free force at a bound whose Newton component leaves the box would be
  // clipped, and the step would be no Newton step for the others (the
  // iteration jams): pin it and solve again on the smaller free set.
  for (int round = 0; round < C::kPinRounds; ++round) {
    bool changed = false;
    for (int i = 0; i < m; ++i) {
      if (held[i]) continue;
      if ((s[i] <= lower[i] && d[i] < 0.0) || (s[i] >= upper[i] && d[i] > 0.0)) {
        held[i] = 1;
        changed = true;
      }
    }
    if (!changed) break;
    ++st.factorizations;
    if (!factorize(held) || !solve_modified(A, rhs, d)) return st.ok = false;
  }
  // A held row of K gives a scaled gradient step out of the box, which the
  // projection would undo; as a zero it does not block the truncated step.
  for (int i = 0; i < m; ++i)
    if (held[i]) d[i] = 0.0;

  // Candidates, judged by the exact decrease of the quadratic (accurate near
  // a non-zero minimum, unlike a difference of objectives): the projected
  // Newton step, Armijo backtracking along the projection arc, and the step
  // truncated at the first bound it meets. The largest decrease wins.
  auto decrease_of = [&](const Eigen::VectorXd& dx) {
    return -g.dot(dx) - 0.5 * (curvature(A, dx) + mu * dx.squaredNorm());
  };
  auto projected_step = [&](double alpha) {
    for (int i = 0; i < m; ++i) step[i] = project(i, s[i] + alpha * d[i]) - s[i];
    return -g.dot(step);  // first-order decrease, for the Armijo test
  };
  double best = 0.0;
  auto consider = [&](double decrease) {
    if (!(decrease > best)) return false;
    best = decrease;
    trial = s + step;
    return true;
  };
  const double predicted_full = projected_step(1.0);
  const double decrease_full = decrease_of(step);
  bool full_step = consider(decrease_full);
  bool clipped = false;  // did the projection change a free component of s + d?
  for (int i = 0; i < m && !clipped; ++i) clipped = !held[i] && project(i, s[i] + d[i]) != s[i] + d[i];
  const bool armijo_full = decrease_full >= C::kArmijo * predicted_full && decrease_full > 0.0;
  // A non-monotone step only from a new best point, which rules out cycling.
  if (!armijo_full && st.nonmonotone_left > 0 && record) {
    --st.nonmonotone_left;
    trial = s + step;
    full_step = true;
    best = kInf;  // taken regardless of the decrease
  } else if (!armijo_full) {
    double alpha_max = 1.0;
    for (int i = 0; i < m; ++i) {
      if (d[i] < 0.0) alpha_max = std::min(alpha_max, (lower[i] - s[i]) / d[i]);
      if (d[i] > 0.0) alpha_max = std::min(alpha_max, (upper[i] - s[i]) / d[i]);
    }
    if (alpha_max > 0.0) {
      projected_step(alpha_max);  // exact up to the blocking bound, which it lands on
      if (consider(decrease_of(step))) full_step = false;
    }
    double alpha = 0.5;
    for (int k = 0; k < C::kArcHalvings; ++k, alpha *= 0.5) {
      const double predicted = projected_step(alpha);
      if (step.lpNorm<Eigen::Infinity>() == 0.0) break;
      const double decrease = decrease_of(step);
      if (decrease > 0.0 && decrease >= C::kArmijo * predicted) {
        if (consider(decrease)) full_step = false;
        break;
      }
    }
  }
  if (!(best > 0.0)) {
    // The Newton direction can fail to descend along the projection arc
    // (pinning ran out of rounds, or rounding); the projected diagonally
    // scaled gradient descends unless sigma is stationary.
    double alpha = 1.0;
    for (int k = 0; k < C::kGradientHalvings; ++k, alpha *= 0.5) {
      for (int i = 0; i < m; ++i) step[i] = project(i, s[i] - alpha * g[i] / diag_n[i]) - s[i];
      if (step.lpNorm<Eigen::Infinity>() == 0.0) break;
      const double predicted = -g.dot(step);
      const double decrease = decrease_of(step);
      if (decrease > 0.0 && decrease >= C::kArmijo * predicted) {
        consider(decrease);
        break;
      }
    }
    full_step = false;
  }
  if (!(best > 0.0)) return false;
  // An unclipped full Newton step solved the subproblem of this held set
  // exactly: if the next gradient holds the same set, the active set has settled.
  st.last_step_exact = full_step && !clipped;
  s = trial;
  return true;
}

}  // namespace stress_qp_detail
}  // namespace tensegrity
