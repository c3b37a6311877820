#include "simulation/actuation.hpp"

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <limits>

#include "simulation/simulator.hpp"
#include "simulation/stability.hpp"

namespace tensegrity {

namespace {

// d sigma_e / d L_e at the current length (N/m).
double force_rest_length_slope(const ElasticModel& model, int e, double l) {
  const double L = model.rest_lengths[e];
  const double eps = l / L - 1.0;
  const double slope = model.curve_of[e] >= 0 ? model.curves[model.curve_of[e]].slope(eps) : model.strut_ea[e];
  return -slope * l / (L * L);
}

// Rows of the free coordinates of the pose's target nodes (-1 for fixed nodes).
std::vector<int> target_rows(const FreeNodeMap& map, const Pose& pose) {
  std::vector<int> rows;
  for (const auto& t : pose.targets) {
    const int slot = map.slot(t.node);
    for (int a = 0; a < 3; ++a) rows.push_back(slot < 0 ? -1 : 3 * slot + a);
  }
  return rows;
}

Eigen::VectorXd target_residual(const Pose& pose, const Eigen::Matrix3Xd& x) {
  Eigen::VectorXd r(3 * pose.targets.size());
  for (std::size_t k = 0; k < pose.targets.size(); ++k)
    r.segment<3>(3 * k) = pose.targets[k].position - x.col(pose.targets[k].node);
  return r;
}

Eigen::MatrixXd pose_jacobian(const Eigen::MatrixXd& dxdl, const std::vector<int>& rows) {
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(rows.size(), dxdl.cols());
  for (std::size_t k = 0; k < rows.size(); ++k)
    if (rows[k] >= 0) J.row(k) = dxdl.row(rows[k]);
  return J;
}

double rms(const Eigen::VectorXd& r) { return r.size() ? std::sqrt(r.squaredNorm() / (r.size() / 3)) : 0.0; }

double max_distance(const Eigen::VectorXd& r) {
  double m = 0.0;
  for (int k = 0; k < r.size() / 3; ++k) m = std::max(m, r.segment<3>(3 * k).norm());
  return m;
}

}  // namespace

Eigen::MatrixXd rest_length_sensitivity(const ElasticEnergy& energy, const Eigen::Matrix3Xd& x) {
  const ElasticModel& model = energy.model();
  const FreeNodeMap& map = energy.free_map();
  Eigen::SparseMatrix<double> H = energy.pattern();
  energy.hessian(x, HessianMode::Exact, H);
  const Eigen::MatrixXd K = Eigen::MatrixXd(H);
  const int m = model.structure.num_elements();
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(energy.num_dofs(), m);
  for (int e = 0; e < m; ++e) {
    const auto& el = model.structure.elements[e];
    const Eigen::Vector3d d = x.col(el.b) - x.col(el.a);
    const double l = d.norm();
    const Eigen::Vector3d u = d / l;
    const double c = force_rest_length_slope(model, e, l);
    // grad_x E gains c dL (d l / d x): -u at a, +u at b.
    if (map.slot(el.a) >= 0) G.block<3, 1>(3 * map.slot(el.a), e) = -c * u;
    if (map.slot(el.b) >= 0) G.block<3, 1>(3 * map.slot(el.b), e) = c * u;
  }
  return -K.ldlt().solve(G);
}

namespace {

struct NonlinearState {
  Eigen::VectorXd dl;     // accepted rest-length changes of the chosen elements (m)
  Eigen::Matrix3Xd x;     // the verified static solve at L + dl
  Eigen::VectorXd r;      // target residual at x
  Eigen::MatrixXd J;      // d(target positions) / d(dl) at x
  int cables_slack = 0;   // at x
};

Eigen::MatrixXd chosen_columns(const Eigen::MatrixXd& J, const std::vector<int>& chosen) {
  Eigen::MatrixXd Js(J.rows(), chosen.size());
  for (std::size_t k = 0; k < chosen.size(); ++k) Js.col(k) = J.col(chosen[k]);
  return Js;
}

// Largest t in (0, 1] such that t * step changes no chosen rest length by
// more than max_relative_change of it.
double step_fraction(const ElasticModel& model, const std::vector<int>& chosen, const NonlinearState& s,
                     const Eigen::VectorXd& step, const ActuationOptions& o) {
  double t = 1.0;
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    const double limit = o.max_relative_change * (model.rest_lengths[chosen[k]] + s.dl[k]);
    if (std::abs(step[k]) > limit) t = std::min(t, limit / std::abs(step[k]));
  }
  return t;
}

// l - L per cable at x (a longer rest length leaves it slack); +inf for struts.
Eigen::VectorXd cable_stretch(const ElasticModel& model, const Eigen::Matrix3Xd& x) {
  const int m = model.structure.num_elements();
  Eigen::VectorXd room = Eigen::VectorXd::Constant(m, std::numeric_limits<double>::infinity());
  for (int e = 0; e < m; ++e) {
    if (model.curve_of[e] < 0) continue;
    const auto& el = model.structure.elements[e];
    room[e] = std::max(0.0, (x.col(el.b) - x.col(el.a)).norm() - model.rest_lengths[e]);
  }
  return room;
}

Eigen::VectorXd chosen_entries(const Eigen::VectorXd& v, const std::vector<int>& chosen) {
  Eigen::VectorXd out(chosen.size());
  for (std::size_t k = 0; k < chosen.size(); ++k) out[k] = v[chosen[k]];
  return out;
}

// min |J d - r| subject to d <= upper: the unconstrained least squares on the
// free entries, the most violated bound made active, until none is violated
// (a few elements: at most one pass per element).
Eigen::VectorXd bounded_least_squares(const Eigen::MatrixXd& J, const Eigen::VectorXd& r, const Eigen::VectorXd& upper) {
  const int n = static_cast<int>(J.cols());
  Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
  std::vector<bool> at_bound(n, false);
  for (int pass = 0; pass <= n; ++pass) {
    std::vector<int> free;
    Eigen::VectorXd rhs = r;
    for (int k = 0; k < n; ++k) {
      if (at_bound[k]) {
        d[k] = upper[k];
        rhs -= upper[k] * J.col(k);
      } else {
        free.push_back(k);
      }
    }
    if (free.empty()) break;
    Eigen::MatrixXd Jf(J.rows(), free.size());
    for (std::size_t k = 0; k < free.size(); ++k) Jf.col(k) = J.col(free[k]);
    const Eigen::VectorXd df = Jf.colPivHouseholderQr().solve(rhs);
    int worst = -1;
    double worst_excess = 0.0;
    for (std::size_t k = 0; k < free.size(); ++k) {
      d[free[k]] = df[k];
      const double excess = df[k] - upper[free[k]];
      if (excess > worst_excess) worst_excess = excess, worst = free[k];
    }
    if (worst < 0) break;
    at_bound[worst] = true;
  }
  return d;
}

// Damped Gauss-Newton on the verified residual from dl = 0.
ElasticModel with_changes(const ElasticModel& model, const std::vector<int>& chosen, const Eigen::VectorXd& dl) {
  ElasticModel changed = model;
  for (std::size_t k = 0; k < chosen.size(); ++k) changed.rest_lengths[chosen[k]] += dl[k];
  return changed;
}

// The start of a level: the previous level's reached state, the new element unchanged.
NonlinearState extend_state(const ElasticModel& model, const Pose& pose, const std::vector<int>& chosen,
                            const NonlinearState& previous) {
  NonlinearState s = previous;
  s.dl = Eigen::VectorXd::Zero(chosen.size());
  s.dl.head(previous.dl.size()) = previous.dl;
  const ElasticEnergy energy(with_changes(model, chosen, s.dl));
  s.J = chosen_columns(pose_jacobian(rest_length_sensitivity(energy, s.x), target_rows(energy.free_map(), pose)),
                       chosen);
  return s;
}

// Gauss-Newton on the verified residual, chosen cables kept taut, steps halved
// until the residual falls; every accepted state is a converged static solve.
NonlinearState solve_pose(const ElasticModel& model, const Pose& pose, const std::vector<int>& chosen,
                          NonlinearState s, const ActuationOptions& o, int& steps_accepted) {
  const FreeNodeMap map = ElasticEnergy(model).free_map();
  steps_accepted = 0;
  for (int it = 0; it < o.newton_iterations; ++it) {
    const Eigen::VectorXd room = o.slack_margin * chosen_entries(cable_stretch(with_changes(model, chosen, s.dl), s.x), chosen);
    const Eigen::VectorXd step = bounded_least_squares(s.J, s.r, room);
    if (!step.allFinite() || step.norm() == 0.0) break;
    bool improved = false;
    for (double t = step_fraction(model, chosen, s, step, o); t > 1e-3 && !improved; t *= 0.5) {
      const Eigen::VectorXd dl_try = s.dl + t * step;
      const ElasticEnergy energy(with_changes(model, chosen, dl_try));
      const RelaxResult rr = relax(energy, s.x);
      if (rr.status != Status::Converged) continue;
      const Eigen::VectorXd r_try = target_residual(pose, rr.positions);
      if (r_try.norm() >= s.r.norm()) continue;
      const Eigen::MatrixXd J_try =
          chosen_columns(pose_jacobian(rest_length_sensitivity(energy, rr.positions), target_rows(map, pose)), chosen);
      if (!J_try.allFinite()) continue;
      improved = true;
      s = {dl_try, rr.positions, r_try, J_try, rr.cables_slack};
      ++steps_accepted;
    }
    if (!improved) break;
  }
  return s;
}

}  // namespace

ActuationResult find_actuators(const ElasticModel& model, const Eigen::Matrix3Xd& equilibrium,
                               const std::vector<Pose>& poses, const ActuationOptions& options) {
  ActuationResult result;
  const ElasticEnergy energy(model);
  const StabilityReport stability = analyze_stability(energy, equilibrium);
  result.stable_start = stability.verdict == Stability::Stable;
  result.message = stability.message;
  if (!result.stable_start) return result;
  const FreeNodeMap& map = energy.free_map();
  const int m = model.structure.num_elements();
  const Eigen::MatrixXd dxdl = rest_length_sensitivity(energy, equilibrium);
  std::vector<Eigen::MatrixXd> J;
  std::vector<Eigen::VectorXd> r0;
  for (const auto& p : poses) {
    J.push_back(pose_jacobian(dxdl, target_rows(map, p)));
    r0.push_back(target_residual(p, equilibrium));
  }
  const Eigen::VectorXd lengthening_room = cable_stretch(model, equilibrium);
  std::vector<int> chosen;
  std::vector<Eigen::VectorXd> residual = r0;
  std::vector<NonlinearState> reached(poses.size());
  for (int level = 0; level < options.max_actuators; ++level) {
    int best = -1;
    double best_gain = 0.0;
    for (int e = 0; e < m; ++e) {
      if (std::find(chosen.begin(), chosen.end(), e) != chosen.end()) continue;
      if (options.cables_only && model.curve_of[e] < 0) continue;
      double gain = 0.0;
      for (std::size_t p = 0; p < poses.size(); ++p) {
        const double nrm2 = J[p].col(e).squaredNorm();
        if (nrm2 == 0.0) continue;
        const double c = J[p].col(e).dot(residual[p]);
        const double a = std::min(c / nrm2, lengthening_room[e]);
        gain += 2.0 * a * c - a * a * nrm2;  // |r|^2 - |r - a J_e|^2
      }
      if (gain > best_gain) {
        best_gain = gain;
        best = e;
      }
    }
    if (best < 0) break;
    chosen.push_back(best);
    ActuationLevel out;
    out.elements = chosen;
    for (std::size_t p = 0; p < poses.size(); ++p) {
      const Eigen::MatrixXd Js = chosen_columns(J[p], chosen);
      PoseResult pr;
      pr.name = poses[p].name;
      const Eigen::VectorXd linear_change = bounded_least_squares(Js, r0[p], chosen_entries(lengthening_room, chosen));
      residual[p] = r0[p] - Js * linear_change;
      pr.initial_error = rms(r0[p]);
      pr.linear_error = rms(residual[p]);
      const NonlinearState start = level == 0 ? NonlinearState{Eigen::VectorXd::Zero(1), equilibrium, r0[p], Js, 0}
                                              : extend_state(model, poses[p], chosen, reached[p]);
      const NonlinearState s = solve_pose(model, poses[p], chosen, start, options, pr.steps_accepted);
      reached[p] = s;
      pr.rest_length_change = s.dl;
      pr.reached_error = rms(s.r);
      pr.max_error = max_distance(s.r);
      pr.cables_slack = s.cables_slack;
      out.poses.push_back(pr);
    }
    result.levels.push_back(std::move(out));
  }
  return result;
}

}  // namespace tensegrity
