#include "simulation/actuation.hpp"

#include <Eigen/Dense>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>

#include "simulation/simulator.hpp"

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

std::vector<ActuationLevel> find_actuators(const ElasticModel& model, const Eigen::Matrix3Xd& equilibrium,
                                           const std::vector<Pose>& poses, const ActuationOptions& options) {
  const ElasticEnergy energy(model);
  const FreeNodeMap& map = energy.free_map();
  const int m = model.structure.num_elements();
  const Eigen::MatrixXd dxdl = rest_length_sensitivity(energy, equilibrium);
  std::vector<Eigen::MatrixXd> J;
  std::vector<Eigen::VectorXd> r0;
  for (const auto& p : poses) {
    J.push_back(pose_jacobian(dxdl, target_rows(map, p)));
    r0.push_back(target_residual(p, equilibrium));
  }
  std::vector<ActuationLevel> levels;
  std::vector<int> chosen;
  std::vector<Eigen::VectorXd> residual = r0;
  for (int level = 0; level < options.max_actuators; ++level) {
    int best = -1;
    double best_gain = 0.0;
    for (int e = 0; e < m; ++e) {
      if (std::find(chosen.begin(), chosen.end(), e) != chosen.end()) continue;
      if (options.cables_only && model.curve_of[e] < 0) continue;
      double gain = 0.0;
      for (std::size_t p = 0; p < poses.size(); ++p) {
        const double nrm = J[p].col(e).norm();
        if (nrm > 0.0) gain += std::pow(J[p].col(e).dot(residual[p]) / nrm, 2);
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
      Eigen::MatrixXd Js(J[p].rows(), chosen.size());
      for (std::size_t k = 0; k < chosen.size(); ++k) Js.col(k) = J[p].col(chosen[k]);
      PoseResult pr;
      pr.name = poses[p].name;
      pr.rest_length_change = Js.colPivHouseholderQr().solve(r0[p]);
      residual[p] = r0[p] - Js * pr.rest_length_change;
      pr.initial_error = rms(r0[p]);
      pr.linear_error = rms(residual[p]);
      // Nonlinear: Gauss-Newton on the relaxed equilibrium, starting from zero.
      ElasticModel trial = model;  // the model at the accepted rest lengths
      Eigen::VectorXd dl = Eigen::VectorXd::Zero(chosen.size());
      Eigen::Matrix3Xd x = equilibrium;
      Eigen::VectorXd r = r0[p];
      Eigen::MatrixXd Jk = Js;
      for (int it = 0; it < options.newton_iterations; ++it) {
        Eigen::VectorXd step = Jk.colPivHouseholderQr().solve(r);
        double worst = 0.0;
        for (std::size_t k = 0; k < chosen.size(); ++k)
          worst = std::max(worst, std::abs(step[k]) / model.rest_lengths[chosen[k]]);
        if (worst > options.max_relative_change) step *= options.max_relative_change / worst;
        // Backtrack on the verified residual.
        bool improved = false;
        for (double t = 1.0; t > 1e-3 && !improved; t *= 0.5) {
          ElasticModel candidate = model;
          const Eigen::VectorXd dl_try = dl + t * step;
          for (std::size_t k = 0; k < chosen.size(); ++k) candidate.rest_lengths[chosen[k]] += dl_try[k];
          const ElasticEnergy ce(candidate);
          const RelaxResult rr = relax(ce, x);
          if (rr.status != Status::Converged) continue;
          const Eigen::VectorXd r_try = target_residual(poses[p], rr.positions);
          if (r_try.norm() < r.norm()) {
            improved = true;
            dl = dl_try;
            x = rr.positions;
            r = r_try;
            trial = std::move(candidate);
          }
        }
        if (!improved) break;
        const ElasticEnergy te(trial);
        const Eigen::MatrixXd Jfull = pose_jacobian(rest_length_sensitivity(te, x), target_rows(map, poses[p]));
        for (std::size_t k = 0; k < chosen.size(); ++k) Jk.col(k) = Jfull.col(chosen[k]);
      }
      pr.rest_length_change = dl;
      pr.reached_error = rms(r);
      pr.max_error = max_distance(r);
      out.poses.push_back(pr);
    }
    levels.push_back(std::move(out));
  }
  return levels;
}

}  // namespace tensegrity
