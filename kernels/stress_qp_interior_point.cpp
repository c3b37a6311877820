// The interior-point phase of the stress QP (kernels/stress_qp.hpp).
#include <algorithm>
#include <array>
#include <cmath>

#include "kernels/stress_qp_impl.hpp"

namespace tensegrity {
namespace stress_qp_detail {

using C = InteriorPointConstants;

// Mehrotra predictor-corrector interior-point method for the bound-
// constrained QP min 1/2 x'Nx + h'x, lower <= x <= upper, from a strictly
// interior point. Why: from a cold start on near-mechanisms (many forces end
// at a bound, A^T A nearly singular) the projected Newton iteration changes
// the active set a few forces at a time and needs hundreds of
// factorizations; the interior-point iteration needs a few dozen whatever the
// number of active bounds, each a factorization of the same pattern. It
// returns a point close to the optimum, whose active set the projected
// Newton iteration then confirms in a few steps. Returns the number of
// factorizations (x is left at the last iterate).
int Impl::interior_point(const SolveState& st, const Eigen::VectorXd& centre, double scale, double give_up_residual,
                         Eigen::VectorXd& x) {
  const SparseMatrix& A = *st.A;
  const Eigen::VectorXd* fg = st.fg;
  for (Eigen::VectorXd* v : {&ip_rd, &ip_d, &ip_rhs, &ip_dx, &ip_dx_aff}) v->resize(m);
  // h = A^T f_g - w^2 t c - mu centre.
  ip_h.setZero(m);
  if (fg) ip_h.noalias() = A.transpose() * (*fg);
  ip_h -= (w2 * target) * c + mu * centre;
  // Strictly interior start: one F0-scale away from every finite bound.
  const double gap = std::max(scale, C::kSmallestMultiplier);
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
  // The relative residual and the mean complementarity of the latest
  // iterates with the dual residual met (oldest first), for the early end.
  std::array<double, C::kSettledWindow + 1> settled_residual{}, settled_gap{};
  int settled = 0;
  auto residual_settled_far = [&](double gap) {
    residual(A, fg, x, r);
    std::rotate(settled_residual.begin(), settled_residual.begin() + 1, settled_residual.end());
    std::rotate(settled_gap.begin(), settled_gap.begin() + 1, settled_gap.end());
    settled_residual.back() = relative_residual(st, x);
    settled_gap.back() = gap;
    if (++settled <= C::kSettledWindow) return false;
    const double now = settled_residual.back();
    for (double then : settled_residual)
      if (!(std::abs(then - now) <= C::kSettledChange * now)) return false;
    return now > C::kSettledAboveGiveUp * give_up_residual && C::kSettledGapFall * gap <= settled_gap.front();
  };
  int factorizations = 0;
  for (int iteration = 0; iteration < C::kMaxIterations; ++iteration) {
    // Dual residual r_d = N x + h - z_l + z_u.
    apply_normal(A, x, ip_rd);
    ip_rd += ip_h - ip_zl + ip_zu;
    const double gap_now = complementarity();
    if (!std::isfinite(gap_now) || !ip_rd.allFinite()) break;
    // The crossover below needs every active bound's slack under its
    // multiplier, and near-mechanisms under gravity have tiny multipliers:
    // hence a complementarity target far below the dual one.
    const bool dual_met = ip_rd.lpNorm<Eigen::Infinity>() <= C::kDualTolerance * scale;
    if (dual_met && gap_now <= C::kComplementarityTolerance * scale * scale) break;
    if (give_up_residual > 0.0 && !dual_met) settled = 0;
    if (give_up_residual > 0.0 && dual_met && residual_settled_far(gap_now)) break;
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
    const double tau = std::pow(std::max(0.0, gap_aff / gap_now), C::kCenteringPower) * gap_now;
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
    const double alpha = step_length(ip_dx, ip_dzl, ip_dzu, C::kFractionToBoundary);
    if (!(alpha > 0.0)) break;
    x += alpha * ip_dx;
    for (int i = 0; i < m; ++i) {
      if (ip_zl[i] > 0.0) ip_zl[i] = std::max(ip_zl[i] + alpha * ip_dzl[i], C::kSmallestMultiplier);
      if (ip_zu[i] > 0.0) ip_zu[i] = std::max(ip_zu[i] + alpha * ip_dzu[i], C::kSmallestMultiplier);
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

}  // namespace stress_qp_detail
}  // namespace tensegrity
