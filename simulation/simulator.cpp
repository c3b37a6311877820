#include "simulation/simulator.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace tensegrity {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// x_i += alpha * dq over the free nodes, into out (fixed nodes copied from x).
void displaced(const FreeNodeMap& map, const Eigen::Matrix3Xd& x, const Eigen::VectorXd& dq, double alpha,
               Eigen::Matrix3Xd& out) {
  out = x;
  for (int i : map.free_nodes()) out.col(i) += alpha * dq.segment<3>(3 * map.slot(i));
}

// Factorises H; true when it is positive definite (every pivot of D > 0).
bool factorize_definite(Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>& ldlt, const Eigen::SparseMatrix<double>& H) {
  ldlt.factorize(H);
  if (ldlt.info() != Eigen::Success) return false;
  const auto& d = ldlt.vectorD();
  return d.size() == 0 || (d.minCoeff() > 0.0 && d.allFinite());
}

double max_abs(const Eigen::VectorXd& v) { return v.size() ? v.cwiseAbs().maxCoeff() : 0.0; }

}  // namespace

// ---- Simulator -----------------------------------------------------------------

Simulator::Simulator(const ElasticModel& model, const Eigen::Vector3d& gravity, const SimulationOptions& options)
    : energy_(model, gravity), options_(options) {
  const FreeNodeMap& map = energy_.free_map();
  x_ = model.reference;
  v_ = Eigen::Matrix3Xd::Zero(3, x_.cols());
  x_prev_ = v_prev_ = x_inertial_ = trial_ = x_;
  const int dofs = energy_.num_dofs();
  mass_dof_.resize(dofs);
  for (int i : map.free_nodes()) mass_dof_.segment<3>(3 * map.slot(i)).setConstant(energy_.lumped_mass()[i]);
  hessian_ = energy_.pattern();
  damping_k_ = energy_.pattern();
  gradient_.resize(dofs);
  step_.resize(dofs);
  gradient_trial_.resize(dofs);
  dq_.resize(dofs);
  kdq_.resize(dofs);
  ldlt_ = std::make_unique<Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>>();
  ldlt_->analyzePattern(hessian_);
}

Simulator::~Simulator() = default;
Simulator::Simulator(Simulator&&) noexcept = default;

void Simulator::set_state(const Eigen::Matrix3Xd& positions, const Eigen::Matrix3Xd& velocities) {
  x_ = positions;
  v_ = velocities;
  for (int i = 0; i < v_.cols(); ++i)
    if (energy_.free_map().slot(i) < 0) v_.col(i).setZero(), x_.col(i) = energy_.model().reference.col(i);
}

double Simulator::kinetic_energy() const {
  const Eigen::VectorXd& m = energy_.lumped_mass();
  double k = 0.0;
  for (int i : energy_.free_map().free_nodes()) k += 0.5 * m[i] * v_.col(i).squaredNorm();
  return k;
}

double Simulator::potential_energy() const { return energy_.energy(x_, drags_); }

void Simulator::free_displacement(const Eigen::Matrix3Xd& x) const {
  const FreeNodeMap& map = energy_.free_map();
  for (int i : map.free_nodes()) dq_.segment<3>(3 * map.slot(i)) = x.col(i) - x_prev_.col(i);
}

double Simulator::merit(const Eigen::Matrix3Xd& x) const {
  const FreeNodeMap& map = energy_.free_map();
  const Eigen::VectorXd& m = energy_.lumped_mass();
  const double h = h_;
  double inertia = 0.0, damping = 0.0;
  for (int i : map.free_nodes()) {
    inertia += m[i] * (x.col(i) - x_inertial_.col(i)).squaredNorm();
    if (options_.mass_damping > 0.0) damping += m[i] * (x.col(i) - x_prev_.col(i)).squaredNorm();
  }
  double value =
      inertia / (2 * h * h) + options_.mass_damping * damping / (2 * h) + energy_.energy(x, active_drags_);
  if (options_.stiffness_damping > 0.0) {
    free_displacement(x);
    kdq_.noalias() = damping_k_ * dq_;
    value += options_.stiffness_damping / (2 * h) * dq_.dot(kdq_);
  }
  return value;
}

double Simulator::merit_gradient(const Eigen::Matrix3Xd& x, Eigen::VectorXd& g) const {
  const FreeNodeMap& map = energy_.free_map();
  const Eigen::VectorXd& m = energy_.lumped_mass();
  const double h = h_, alpha = options_.mass_damping;
  double value = energy_.energy_gradient(x, g, active_drags_);
  for (int i : map.free_nodes()) {
    const Eigen::Vector3d a = x.col(i) - x_inertial_.col(i), b = x.col(i) - x_prev_.col(i);
    value += m[i] * a.squaredNorm() / (2 * h * h) + alpha * m[i] * b.squaredNorm() / (2 * h);
    g.segment<3>(3 * map.slot(i)) += m[i] * (a / (h * h) + alpha * b / h);
  }
  if (options_.stiffness_damping > 0.0) {
    free_displacement(x);
    kdq_.noalias() = damping_k_ * dq_;
    value += options_.stiffness_damping / (2 * h) * dq_.dot(kdq_);
    g += (options_.stiffness_damping / h) * kdq_;
  }
  return value;
}

void Simulator::set_active_drags(double fraction) {
  active_drags_ = drags_;
  // The whole step: the targets as given, bit for bit.
  if (fraction == 1.0) return;
  for (std::size_t k = 0; k < active_drags_.size(); ++k) {
    const Eigen::Vector3d& start = drag_start_targets_[k];
    active_drags_[k].target = start + fraction * (drags_[k].target - start);
  }
}

StepReport Simulator::step() {
  const auto t0 = Clock::now();
  StepReport report;
  report.converged = true;
  report.substeps = 0;
  const double h = options_.time_step;
  report.smallest_substep = h;
  drag_start_targets_.resize(drags_.size());
  for (std::size_t k = 0; k < drags_.size(); ++k) {
    drag_start_targets_[k] = drags_[k].target;
    for (const DragSpring& p : previous_drags_)
      if (p.node == drags_[k].node) drag_start_targets_[k] = p.target;
  }
  const double t_start = time_;
  advance(h, 0, 0.0, 1.0, report);
  time_ = t_start + h;
  previous_drags_ = drags_;
  report.seconds = seconds_since(t0);
  return report;
}

void Simulator::advance(double h, int halvings, double fraction_start, double fraction_span, StepReport& report) {
  StepReport attempt;
  const bool converged = newton_step(h, fraction_start + fraction_span, attempt);
  report.newton_iterations += attempt.newton_iterations;
  report.definite_fallbacks += attempt.definite_fallbacks;
  if (converged || halvings >= options_.max_substep_halvings) {
    report.converged = report.converged && converged;
    ++report.substeps;
    report.smallest_substep = std::min(report.smallest_substep, h);
    report.gradient_norm = std::max(report.gradient_norm, attempt.gradient_norm);
    report.velocity_jump += attempt.velocity_jump;
    report.bregman += attempt.bregman;
    return;
  }
  // Back to the start of this (sub)step, then two halves of it.
  ++report.retries;
  x_ = x_prev_;
  v_ = v_prev_;
  advance(0.5 * h, halvings + 1, fraction_start, 0.5 * fraction_span, report);
  advance(0.5 * h, halvings + 1, fraction_start + 0.5 * fraction_span, 0.5 * fraction_span, report);
}

bool Simulator::newton_step(double h, double drag_fraction, StepReport& report) {
  const FreeNodeMap& map = energy_.free_map();
  h_ = h;
  set_active_drags(drag_fraction);
  const double force_tol = options_.tolerance * energy_.model().force_scale;
  const double diagonal_mass_factor = 1.0 / (h * h) + options_.mass_damping / h;
  x_prev_ = x_;
  v_prev_ = v_;
  x_inertial_ = x_ + h * v_;
  if (options_.stiffness_damping > 0.0) energy_.hessian(x_prev_, HessianMode::Definite, damping_k_);
  x_ = x_inertial_;  // the predictor: exact for free flight

  double* values = hessian_.valuePtr();
  for (int it = 0; it < options_.max_newton_iterations; ++it) {
    const double phi = merit_gradient(x_, gradient_);
    report.gradient_norm = max_abs(gradient_);
    if (report.gradient_norm <= force_tol) {
      report.converged = true;
      break;
    }
    auto assemble = [&](HessianMode mode, double shift) {
      energy_.hessian(x_, mode, hessian_, active_drags_);
      for (int k = 0; k < energy_.num_dofs(); ++k)
        values[energy_.diagonal_slot(k)] += mass_dof_[k] * diagonal_mass_factor + shift;
      if (options_.stiffness_damping > 0.0) {
        const double c = options_.stiffness_damping / h;
        const double* kv = damping_k_.valuePtr();
        for (Eigen::Index s = 0; s < hessian_.nonZeros(); ++s) values[s] += c * kv[s];
      }
    };
    bool ok = false;
    if (options_.exact_hessian_when_definite) {
      assemble(HessianMode::Exact, 0.0);
      ok = factorize_definite(*ldlt_, hessian_);
    }
    if (!ok) {
      ++report.definite_fallbacks;
      double shift = 0.0;
      for (int attempt = 0; attempt < 30 && !ok; ++attempt) {
        assemble(HessianMode::Definite, shift);
        ok = factorize_definite(*ldlt_, hessian_);
        shift = shift == 0.0 ? 1e-12 * (mass_dof_.maxCoeff() * diagonal_mass_factor + 1.0) : 100.0 * shift;
      }
      if (!ok) break;
    }
    step_ = ldlt_->solve(gradient_);
    step_ = -step_;
    const double slope = gradient_.dot(step_);
    ++report.newton_iterations;
    double alpha = 1.0;
    bool accepted = false;
    for (int ls = 0; ls < 40; ++ls, alpha *= 0.5) {
      displaced(map, x_, step_, alpha, trial_);
      energy_.restore_strut_lengths(x_, trial_);
      const double phi_trial = merit(trial_);
      if (phi_trial <= phi + 1e-4 * alpha * slope) {
        accepted = true;
        break;
      }
      // In the round-off regime of Phi, trust the gradient instead.
      if (ls == 0 && std::abs(phi_trial - phi) <= 1e-12 * (std::abs(phi) + 1.0)) {
        merit_gradient(trial_, gradient_trial_);
        if (max_abs(gradient_trial_) < report.gradient_norm) {
          accepted = true;
          break;
        }
      }
    }
    if (!accepted) break;
    x_.swap(trial_);
    // Round-off floor: a step this small cannot lower the gradient any further.
    if (alpha * max_abs(step_) <= 1e-14 * energy_.model().length_scale) break;
  }
  if (!report.converged) {
    merit_gradient(x_, gradient_);
    report.gradient_norm = max_abs(gradient_);
    report.converged = report.gradient_norm <= force_tol;
  }
  v_ = (x_ - x_prev_) / h;

  // Dissipation bookkeeping: 1/2 |dv|_M^2 and the Bregman divergence of E.
  const Eigen::VectorXd& m = energy_.lumped_mass();
  double jump = 0.0, linear = 0.0;
  const double e_new = energy_.energy_gradient(x_, gradient_, active_drags_);
  for (int i : map.free_nodes()) {
    jump += 0.5 * m[i] * (v_.col(i) - v_prev_.col(i)).squaredNorm();
    linear += gradient_.segment<3>(3 * map.slot(i)).dot(x_prev_.col(i) - x_.col(i));
  }
  report.velocity_jump = jump;
  report.bregman = energy_.energy(x_prev_, active_drags_) - e_new - linear;
  return report.converged;
}

// ---- relax ----------------------------------------------------------------------

RelaxResult relax(const ElasticEnergy& energy, const Eigen::Matrix3Xd& start, std::span<const DragSpring> drags,
                  const RelaxOptions& options) {
  const auto t0 = Clock::now();
  const ElasticModel& model = energy.model();
  const FreeNodeMap& map = energy.free_map();
  RelaxResult r;
  r.positions = start;
  auto finish = [&](Status status, std::string message) {
    r.status = status;
    r.message = std::move(message);
    r.forces = energy.element_forces(r.positions);
    r.max_displacement = 0.0;
    for (int i = 0; i < r.positions.cols(); ++i) {
      const double d = (r.positions.col(i) - model.reference.col(i)).norm();
      if (d > r.max_displacement || r.max_displacement_node < 0) r.max_displacement = d, r.max_displacement_node = i;
    }
    r.cables_slack = 0;
    for (int e = 0; e < r.forces.size(); ++e)
      if (model.curve_of[e] >= 0 && r.forces[e] <= 0.0) ++r.cables_slack;
    r.cables_outside_range = energy.cables_outside_measured_range(r.positions);
    r.seconds = seconds_since(t0);
    return r;
  };
  bool held = false;
  for (bool f : model.structure.fixed) held = held || f;
  for (const DragSpring& d : drags) held = held || d.stiffness > 0.0;
  if (energy.gravity().squaredNorm() > 0.0 && !held)
    return finish(Status::Infeasible, "gravity with no fixed node and no drag: the structure falls, no equilibrium");
  if (energy.num_dofs() == 0) return finish(Status::Converged, "no free node");

  const double force_tol = options.tolerance * model.force_scale;
  const int dofs = energy.num_dofs();
  Eigen::SparseMatrix<double> H = energy.pattern();
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  ldlt.analyzePattern(H);
  Eigen::VectorXd g(dofs), step(dofs), g_trial(dofs);
  Eigen::Matrix3Xd trial = start;
  double shift_level = 0.0;  // Levenberg shift, relative to the mean diagonal
  for (r.iterations = 0; r.iterations < options.max_iterations; ++r.iterations) {
    r.energy = energy.energy_gradient(r.positions, g, drags);
    r.gradient_norm = max_abs(g);
    if (!std::isfinite(r.energy) || !g.allFinite()) return finish(Status::NumericalError, "non-finite energy");
    if (r.gradient_norm <= force_tol)
      return finish(Status::Converged, "max net force " + std::to_string(r.gradient_norm) + " N");
    bool ok = false;
    if (shift_level == 0.0) {
      energy.hessian(r.positions, HessianMode::Exact, H, drags);
      ok = factorize_definite(ldlt, H);
    }
    if (!ok) {
      ++r.definite_steps;
      for (int attempt = 0; attempt < 40 && !ok; ++attempt) {
        energy.hessian(r.positions, HessianMode::Definite, H, drags);
        const double mean_diagonal = H.diagonal().cwiseAbs().mean() + 1e-300;
        for (int k = 0; k < dofs; ++k) H.valuePtr()[energy.diagonal_slot(k)] += shift_level * mean_diagonal;
        ok = factorize_definite(ldlt, H);
        if (!ok) shift_level = shift_level == 0.0 ? 1e-12 : 10.0 * shift_level;
      }
      if (!ok) return finish(Status::NumericalError, "the definite Hessian could not be factorised");
    }
    step = -ldlt.solve(g);
    const double slope = g.dot(step);
    double alpha = 1.0;
    bool accepted = false;
    for (int ls = 0; ls < 30; ++ls, alpha *= 0.5) {
      displaced(map, r.positions, step, alpha, trial);
      energy.restore_strut_lengths(r.positions, trial);
      const double e_trial = energy.energy(trial, drags);
      if (std::isfinite(e_trial) && e_trial <= r.energy + 1e-4 * alpha * slope) {
        accepted = true;
        break;
      }
      if (ls == 0 && std::abs(e_trial - r.energy) <= 1e-12 * (std::abs(r.energy) + 1.0)) {
        energy.energy_gradient(trial, g_trial, drags);
        if (max_abs(g_trial) < r.gradient_norm) {
          accepted = true;
          break;
        }
      }
    }
    if (accepted) {
      r.positions.swap(trial);
      if (alpha * max_abs(step) <= 1e-14 * model.length_scale) {
        r.energy = energy.energy_gradient(r.positions, g, drags);
        r.gradient_norm = max_abs(g);
        return finish(r.gradient_norm <= 10 * force_tol ? Status::Converged : Status::MaxIterations,
                      "stalled at the round-off floor, max net force " + std::to_string(r.gradient_norm) + " N");
      }
      // A full step on the unshifted Hessian: let the shift decay.
      shift_level = alpha == 1.0 ? (shift_level < 1e-10 ? 0.0 : 0.1 * shift_level) : shift_level;
    } else {
      shift_level = shift_level == 0.0 ? 1e-8 : 100.0 * shift_level;
      if (shift_level > 1e12) return finish(Status::NumericalError, "line search failed at every shift");
    }
  }
  r.energy = energy.energy_gradient(r.positions, g, drags);
  r.gradient_norm = max_abs(g);
  if (r.gradient_norm <= force_tol) return finish(Status::Converged, "converged at the iteration limit");
  return finish(Status::MaxIterations, "max net force " + std::to_string(r.gradient_norm) + " N after " +
                                           std::to_string(options.max_iterations) + " iterations");
}

}  // namespace tensegrity
