#pragma once
// Disconnected parts of a scene are independent problems. Two free nodes belong
// to the same part when an element joins them; an element with one fixed end
// belongs to the part of its free end; fixed nodes are copied into every part
// that touches them (they are constants). Elements between two fixed nodes
// belong to no part: they carry no equilibrium condition and only obey signs.
#include <vector>

#include "model/structure.hpp"

namespace tensegrity {

struct Part {
  Structure structure;          // local numbering, validated
  std::vector<int> nodes;       // local node -> scene node
  std::vector<int> elements;    // local element -> scene element
};

struct Partition {
  std::vector<Part> parts;
  std::vector<int> unattached_elements;  // between two fixed nodes
  // Free nodes that no element touches: they form no part (there is nothing to
  // solve); they are in equilibrium exactly when they carry no weight.
  std::vector<int> isolated_nodes;
};

// Parts are ordered by their lowest scene node; inside a part, nodes and
// elements keep their scene order.
Partition split_into_parts(const Structure& s);

}  // namespace tensegrity
