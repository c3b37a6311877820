#include "formulations/free_nodes.hpp"

namespace tensegrity {

FreeNodeMap::FreeNodeMap(const Structure& s) : slot_(s.num_nodes(), -1) {
  // Generators may leave `fixed` short; a missing flag means free.
  for (int i = 0; i < s.num_nodes(); ++i) {
    const bool is_fixed = i < static_cast<int>(s.fixed.size()) && s.fixed[i];
    if (is_fixed) continue;
    slot_[i] = num_free_++;
    free_nodes_.push_back(i);
  }
}

Eigen::VectorXd FreeNodeMap::gather(const Eigen::Matrix3Xd& positions) const {
  Eigen::VectorXd q(3 * num_free_);
  for (int k = 0; k < num_free_; ++k) q.segment<3>(3 * k) = positions.col(free_nodes_[k]);
  return q;
}

void FreeNodeMap::scatter(const Eigen::VectorXd& q, Eigen::Matrix3Xd& positions) const {
  for (int k = 0; k < num_free_; ++k) positions.col(free_nodes_[k]) = q.segment<3>(3 * k);
}

}  // namespace tensegrity
