#pragma once
// Index map between scene nodes and unknowns: only free (non-fixed) nodes are
// unknowns and carry equilibrium equations. Built once per topology.
#include <Eigen/Core>
#include <vector>

#include "model/structure.hpp"

namespace tensegrity {

class FreeNodeMap {
 public:
  explicit FreeNodeMap(const Structure& s);
  int num_nodes() const { return static_cast<int>(slot_.size()); }
  int num_free() const { return num_free_; }
  // Position of node i among the free nodes, or -1 when i is fixed. Its three
  // coordinates are the unknowns 3*slot(i) .. 3*slot(i)+2.
  int slot(int node) const { return slot_[node]; }
  const std::vector<int>& free_nodes() const { return free_nodes_; }

  // Free coordinates stacked (3 n_free) <-> full positions (3 x n).
  Eigen::VectorXd gather(const Eigen::Matrix3Xd& positions) const;
  void scatter(const Eigen::VectorXd& q, Eigen::Matrix3Xd& positions) const;

 private:
  std::vector<int> slot_;
  std::vector<int> free_nodes_;
  int num_free_ = 0;
};

}  // namespace tensegrity
