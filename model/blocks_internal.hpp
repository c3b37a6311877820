#pragma once
// Helpers shared by the block generators (blocks.cpp), the self-stress search
// (block_self_stress.cpp) and the block file I/O (block_library.cpp); not part
// of the model's interface.
#include <string>
#include <vector>

#include "model/blocks.hpp"

namespace tensegrity::block_detail {

// Gives every element an extra object (the generators and readers write names into it).
void ensure_extras(Structure& s);

// Writes names[e] into element e's extra and lists the named cables in b.cables.
void set_cable_names(Block& b, const std::vector<std::string>& names);

}  // namespace tensegrity::block_detail
