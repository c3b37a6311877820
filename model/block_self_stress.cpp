#include <Eigen/Dense>
#include <algorithm>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

#include "model/blocks.hpp"
#include "model/blocks_internal.hpp"

namespace tensegrity {

namespace {

// Segments this close to parallel (relative sine squared) are treated as
// parallel: the closest-point formula divides by it.
constexpr double kParallelSegments = 1e-14;
// Singular values below this fraction of the largest count as zero: the
// equilibrium matrix has unit columns, so genuine couplings are far larger.
constexpr double kRelativeRankTolerance = 1e-10;

}  // namespace

using block_detail::ensure_extras;

double segment_distance(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& q0,
                        const Eigen::Vector3d& q1) {
  // Closest points of two segments (Ericson, Real-Time Collision Detection, 5.1.9).
  const Eigen::Vector3d d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  const double c = d1.dot(r), b = d1.dot(d2), denom = a * e - b * b;
  double s = denom > kParallelSegments * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  double t = (b * s + f) / e;
  if (t < 0.0) {
    t = 0.0;
    s = std::clamp(-c / a, 0.0, 1.0);
  } else if (t > 1.0) {
    t = 1.0;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
  return ((p0 + s * d1) - (q0 + t * d2)).norm();
}

bool find_signed_self_stress(const Structure& s, Eigen::VectorXd* forces) {
  const int n = s.num_nodes(), m = s.num_elements();
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * n, m);
  for (int e = 0; e < m; ++e) {
    const auto& el = s.elements[e];
    const Eigen::Vector3d u = (s.positions.col(el.b) - s.positions.col(el.a)).normalized();
    A.block<3, 1>(3 * el.a, e) = u;
    A.block<3, 1>(3 * el.b, e) = -u;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::VectorXd& sv = svd.singularValues();
  int rank = 0;
  for (int k = 0; k < sv.size(); ++k) rank += sv[k] > kRelativeRankTolerance * sv[0];
  if (rank == m) return false;
  const Eigen::MatrixXd N = svd.matrixV().rightCols(m - rank);
  Eigen::VectorXd sign(m);
  for (int e = 0; e < m; ++e) sign[e] = s.elements[e].kind == ElementKind::Cable ? 1.0 : -1.0;
  constexpr int kMaxSweeps = 5000;
  constexpr double kAcceptedMargin = 0.5;  // of the box's margin 1
  constexpr double kStalledStep = 1e-10;   // relative change of a sweep at a fixed point
  // The projections run thousands of times per candidate tie: buffers are
  // allocated once so the loop itself does not allocate.
  Eigen::VectorXd coefficients = N.transpose() * sign;
  Eigen::VectorXd sigma = N * coefficients;
  Eigen::VectorXd signed_sigma(m), boxed(m);
  for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
    signed_sigma = sigma.cwiseProduct(sign);
    const double margin = signed_sigma.minCoeff();
    if (margin >= kAcceptedMargin) {
      *forces = sigma / margin;
      return true;
    }
    boxed = signed_sigma.cwiseMax(1.0).cwiseProduct(sign);
    coefficients.noalias() = N.transpose() * boxed;
    // Projections onto two convex sets converge; once they no longer move, the
    // sets do not meet within reach and further sweeps cannot find a margin.
    boxed.noalias() = N * coefficients;
    const double step = (boxed - sigma).norm();
    sigma.swap(boxed);
    if (step <= kStalledStep * sigma.norm()) return false;
  }
  return false;
}

Structure with_ties(const Block& b, int count) {
  Structure s = b.structure;
  ensure_extras(s);
  for (int k = 0; k < count; ++k) {
    const int e = s.add_element(b.ties[k][0], b.ties[k][1], ElementKind::Cable);
    s.element_extra.resize(s.num_elements(), nlohmann::json::object());
    s.element_extra[e] = {{"name", "tie-" + std::to_string(k)}};
  }
  return s;
}

void add_interior_ties(Block& b, int max_ties, double tie_clearance) {
  const Structure& s = b.structure;
  double strut_length = 0.0;
  std::set<std::pair<int, int>> joined;
  for (const auto& el : s.elements) {
    joined.insert(std::minmax(el.a, el.b));
    if (el.kind == ElementKind::Strut)
      strut_length = std::max(strut_length, (s.positions.col(el.b) - s.positions.col(el.a)).norm());
  }
  for (const auto& t : b.ties) joined.insert(std::minmax(t[0], t[1]));
  std::vector<std::tuple<double, int, int>> candidates;
  for (int i = 0; i < s.num_nodes(); ++i)
    for (int j = i + 1; j < s.num_nodes(); ++j)
      if (!joined.count({i, j})) candidates.emplace_back((s.positions.col(j) - s.positions.col(i)).norm(), i, j);
  std::sort(candidates.begin(), candidates.end());
  const double clearance = tie_clearance * strut_length;
  int added = 0;
  for (const auto& [length, i, j] : candidates) {
    if (added == max_ties) break;
    Structure trial = with_ties(b, static_cast<int>(b.ties.size()));
    bool clear = true;
    for (const auto& el : trial.elements) {
      if (el.a == i || el.a == j || el.b == i || el.b == j) continue;
      if (segment_distance(s.positions.col(i), s.positions.col(j), s.positions.col(el.a), s.positions.col(el.b)) <
          clearance) {
        clear = false;
        break;
      }
    }
    if (!clear) continue;
    trial.add_element(i, j, ElementKind::Cable);
    Eigen::VectorXd sigma;
    if (!find_signed_self_stress(trial, &sigma)) continue;
    b.ties.push_back({i, j});
    ++added;
  }
}

double relative_self_stress_residual(const Structure& s, const Eigen::Matrix3Xd& positions,
                                     const Eigen::VectorXd& forces) {
  Eigen::Matrix3Xd net = Eigen::Matrix3Xd::Zero(3, s.num_nodes());
  for (int e = 0; e < s.num_elements(); ++e) {
    const auto& el = s.elements[e];
    const Eigen::Vector3d u = (positions.col(el.b) - positions.col(el.a)).normalized();
    net.col(el.a) += forces[e] * u;
    net.col(el.b) -= forces[e] * u;
  }
  double worst = 0.0;
  for (int i = 0; i < s.num_nodes(); ++i)
    if (!s.fixed[i]) worst = std::max(worst, net.col(i).norm());
  return worst / forces.cwiseAbs().maxCoeff();
}

}  // namespace tensegrity
