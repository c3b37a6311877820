#include <Eigen/Geometry>
#include <algorithm>
#include <filesystem>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "model/blocks.hpp"
#include "model/blocks_internal.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/json_text.hpp"
#include "model/known_keys.hpp"
#include "model/scene_io.hpp"

namespace tensegrity {

using block_detail::ensure_extras;
using block_detail::set_cable_names;

namespace {

// The keys of a block file (docs/FORMATS.md).
const std::vector<std::string_view> kBlockKeys = {"format", "version", "name",     "source",
                                                                "counts", "nodes",   "elements", "faces", "ties"};
const std::vector<std::string_view> kBlockCountKeys = {"nodes", "struts", "cables"};
const std::vector<std::string_view> kBlockElementKeys = {"kind", "nodes", "force", "name"};
const std::vector<std::string_view> kBlockFaceKeys = {"name", "nodes", "normal"};

Eigen::Vector3d face_normal(const Structure& s, const std::array<int, 3>& f) {
  const Eigen::Vector3d a = s.positions.col(f[0]), b = s.positions.col(f[1]), c = s.positions.col(f[2]);
  Eigen::Vector3d nrm = (b - a).cross(c - a).normalized();
  const Eigen::Vector3d centre = s.positions.rowwise().mean();
  if (nrm.dot((a + b + c) / 3.0 - centre) < 0.0) nrm = -nrm;
  return nrm;
}

}  // namespace

nlohmann::json block_to_json(const Block& b) {
  using nlohmann::json;
  json j;
  j["format"] = "tensegrity-block";
  j["version"] = 1;
  j["name"] = b.name;
  j["source"] = b.source;
  j["counts"] = {{"nodes", b.structure.num_nodes()}, {"struts", b.num_struts()}, {"cables", b.num_cables()}};
  json nodes = json::array();
  for (int i = 0; i < b.structure.num_nodes(); ++i) {
    const Eigen::Vector3d x = b.structure.positions.col(i);
    nodes.push_back({x.x(), x.y(), x.z()});
  }
  j["nodes"] = nodes;
  json elements = json::array();
  for (int e = 0; e < b.structure.num_elements(); ++e) {
    const auto& el = b.structure.elements[e];
    json je;
    je["kind"] = to_string(el.kind);
    je["nodes"] = {el.a, el.b};
    je["force"] = b.forces[e];
    if (e < static_cast<int>(b.structure.element_extra.size()) && b.structure.element_extra[e].contains("name"))
      je["name"] = b.structure.element_extra[e]["name"];
    elements.push_back(je);
  }
  j["elements"] = elements;
  json faces = json::array();
  for (const auto& [name, f] : b.faces) {
    const Eigen::Vector3d nrm = face_normal(b.structure, f);
    faces.push_back({{"name", name}, {"nodes", {f[0], f[1], f[2]}}, {"normal", {nrm.x(), nrm.y(), nrm.z()}}});
  }
  j["faces"] = faces;
  if (!b.ties.empty()) {
    json ties = json::array();
    for (const auto& t : b.ties) ties.push_back({t[0], t[1]});
    j["ties"] = ties;
  }
  return j;
}

Block block_from_json(const nlohmann::json& j, const std::string& source) {
  json_expect_header(j, "tensegrity-block", source);
  KeyChecker keys(source);
  keys.check(j, kBlockKeys, "");
  if (j.contains("counts")) keys.check(j["counts"], kBlockCountKeys, "counts");
  Block b;
  if (!j.contains("name")) throw InputError(source, "name", "missing");
  b.name = json_string(j["name"], source, "name");
  if (j.contains("source")) b.source = json_string(j["source"], source, "source");
  b.structure.name = b.name;
  if (!j.contains("nodes") || !j["nodes"].is_array() || j["nodes"].empty())
    throw InputError(source, "nodes", "missing or not a non-empty array");
  for (std::size_t i = 0; i < j["nodes"].size(); ++i)
    b.structure.add_node(json_vector3(j["nodes"][i], source, "nodes[" + std::to_string(i) + "]"));
  const int n = b.structure.num_nodes();
  if (!j.contains("elements") || !j["elements"].is_array() || j["elements"].empty())
    throw InputError(source, "elements", "missing or not a non-empty array");
  const auto& elements = j["elements"];
  b.forces.resize(elements.size());
  std::vector<std::string> names;
  for (std::size_t e = 0; e < elements.size(); ++e) {
    const std::string item = "elements[" + std::to_string(e) + "]";
    const auto& je = elements[e];
    if (!je.is_object()) throw InputError(source, item, "not an object");
    keys.check(je, kBlockElementKeys, item);
    const std::string kind = je.contains("kind") ? json_string(je["kind"], source, item + ".kind") : "";
    ElementKind k;
    if (kind == "strut")
      k = ElementKind::Strut;
    else if (kind == "cable")
      k = ElementKind::Cable;
    else
      throw InputError(source, item + ".kind", "must be \"strut\" or \"cable\"");
    if (!je.contains("nodes") || !je["nodes"].is_array() || je["nodes"].size() != 2)
      throw InputError(source, item + ".nodes", "must be two node indices");
    const int a = json_index(je["nodes"][0], n, "node", source, item + ".nodes[0]");
    const int c = json_index(je["nodes"][1], n, "node", source, item + ".nodes[1]");
    if (!je.contains("force")) throw InputError(source, item + ".force", "missing");
    const double f = json_finite_number(je["force"], source, item + ".force");
    if (k == ElementKind::Cable ? f <= 0.0 : f >= 0.0)
      throw InputError(source, item + ".force", "a " + kind + " force must be " + (k == ElementKind::Cable ? "> 0" : "< 0"));
    b.forces[e] = f;
    names.push_back(je.contains("name") ? json_string(je["name"], source, item + ".name") : "");
    b.structure.add_element(a, c, k);
  }
  ensure_extras(b.structure);
  for (std::size_t e = 0; e < names.size(); ++e) {
    if (names[e].empty()) continue;
    if (b.structure.elements[e].kind == ElementKind::Cable && b.cables.count(names[e]))
      throw InputError(source, "elements[" + std::to_string(e) + "].name", "duplicate cable name '" + names[e] + "'");
  }
  set_cable_names(b, names);
  if (j.contains("faces")) {
    if (!j["faces"].is_array()) throw InputError(source, "faces", "must be an array");
    for (std::size_t i = 0; i < j["faces"].size(); ++i) {
      const std::string item = "faces[" + std::to_string(i) + "]";
      const auto& jf = j["faces"][i];
      keys.check(jf, kBlockFaceKeys, item);
      if (!jf.is_object() || !jf.contains("name") || !jf.contains("nodes") || !jf["nodes"].is_array() ||
          jf["nodes"].size() != 3)
        throw InputError(source, item, "must be an object with a name and three node indices");
      std::array<int, 3> f{};
      for (int k = 0; k < 3; ++k) f[k] = json_index(jf["nodes"][k], n, "node", source, item + ".nodes");
      if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) throw InputError(source, item, "repeats a node");
      const std::string name = json_string(jf["name"], source, item + ".name");
      if (b.faces.count(name)) throw InputError(source, item, "duplicate face name '" + name + "'");
      b.faces[name] = f;
    }
  }
  if (j.contains("ties")) {
    if (!j["ties"].is_array()) throw InputError(source, "ties", "must be an array of node pairs");
    std::set<std::pair<int, int>> joined;
    for (const auto& el : b.structure.elements) joined.insert(std::minmax(el.a, el.b));
    for (std::size_t i = 0; i < j["ties"].size(); ++i) {
      const std::string item = "ties[" + std::to_string(i) + "]";
      const auto& jt = j["ties"][i];
      if (!jt.is_array() || jt.size() != 2) throw InputError(source, item, "must be two node indices");
      const int a = json_index(jt[0], n, "node", source, item + "[0]");
      const int c = json_index(jt[1], n, "node", source, item + "[1]");
      if (a == c) throw InputError(source, item, "joins a node to itself");
      if (!joined.insert(std::minmax(a, c)).second)
        throw InputError(source, item, "joins two nodes already joined");
      b.ties.push_back({a, c});
    }
  }
  validate(b.structure, source);
  keys.report();
  return b;
}

Block read_block_file(const std::string& path) { return block_from_json(read_json_file(path), path); }

void write_block_file(const Block& b, const std::string& path) {
  write_text_file_atomically(path, to_json_text(block_to_json(b)) + "\n");
}

BlockLibrary BlockLibrary::load(const std::string& directory) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(directory, ec)) throw InputError(directory, "", "block library folder not found");
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(directory, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.size() > 11 && name.substr(name.size() - 11) == ".block.json") files.push_back(entry.path());
  }
  if (files.empty()) throw InputError(directory, "", "no *.block.json files in the block library folder");
  std::sort(files.begin(), files.end());
  BlockLibrary lib;
  for (const auto& f : files) lib.add(read_block_file(f.string()));
  return lib;
}

BlockLibrary BlockLibrary::standard() {
  BlockLibrary lib;
  for (auto& b : make_standard_blocks()) lib.add(std::move(b));
  return lib;
}

void BlockLibrary::add(Block b) {
  std::string name = b.name;
  blocks_[name] = std::move(b);
}

const Block& BlockLibrary::get(const std::string& name, const std::string& source,
                               const std::string& item) const {
  auto it = blocks_.find(name);
  if (it == blocks_.end()) {
    std::string known;
    for (const auto& [n, b] : blocks_) known += (known.empty() ? "" : ", ") + n;
    throw InputError(source, item, "unknown block type '" + name + "' (library: " + known + ")");
  }
  return it->second;
}

std::vector<std::string> BlockLibrary::names() const {
  std::vector<std::string> out;
  for (const auto& [n, b] : blocks_) out.push_back(n);
  return out;
}

Eigen::Matrix3Xd instance_positions(const Block& b, const BlockTransform& t) {
  Eigen::Matrix3Xd x = b.structure.positions;
  for (const auto& [node, d] : t.displacements) x.col(node) += d;
  Eigen::Matrix3Xd out = (t.scale * t.rotation) * x;
  out.colwise() += t.translation;
  return out;
}

}  // namespace tensegrity
