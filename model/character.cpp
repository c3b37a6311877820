#include "model/character.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <numeric>
#include <set>
#include <stdexcept>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/known_keys.hpp"
#include "model/links.hpp"
#include "model/scene_io.hpp"

namespace tensegrity {

namespace {

// The keys of a character file (docs/FORMATS.md).
const std::vector<std::string_view> kCharacterKeys = {
    "format", "version", "name", "description", "block_library", "gravity",
    "strut_density", "cable_density", "blocks", "links", "ground"};
const std::vector<std::string_view> kBlockInstanceKeys = {
    "id", "type", "scale", "rotation_deg", "translation", "displacements", "ties"};
const std::vector<std::string_view> kDisplacementKeys = {"node", "by"};
const std::vector<std::string_view> kLinkKeys = {"id", "type", "a", "b", "depth"};
const std::vector<std::string_view> kLinkSideKeys = {"block", "face", "facing", "toward", "cable"};
const std::vector<std::string_view> kGroundKeys = {"block", "lowest", "nodes"};

struct Instance {
  std::string id;
  const Block* block = nullptr;
  std::vector<int> node_map;     // template node -> scene node
  std::vector<int> element_ids;  // template element -> scene element (-1 once removed)
  std::set<std::string> used_faces;
};

double json_positive(const nlohmann::json& v, const std::string& source, const std::string& item) {
  const double x = json_finite_number(v, source, item);
  if (!(x > 0.0)) throw InputError(source, item, "must be > 0");
  return x;
}

Eigen::Matrix3d rotation_from_degrees(const Eigen::Vector3d& deg) {
  const Eigen::Vector3d r = deg * (M_PI / 180.0);
  return (Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d instance_centroid(const Structure& s, const Instance& inst) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int i : inst.node_map) c += s.positions.col(i);
  return c / static_cast<double>(inst.node_map.size());
}

Eigen::Vector3d scene_face_normal(const Structure& s, const Instance& inst, const std::array<int, 3>& f) {
  const Eigen::Vector3d a = s.positions.col(inst.node_map[f[0]]), b = s.positions.col(inst.node_map[f[1]]),
                        c = s.positions.col(inst.node_map[f[2]]);
  Eigen::Vector3d n = (b - a).cross(c - a).normalized();
  if (n.dot((a + b + c) / 3.0 - instance_centroid(s, inst)) < 0.0) n = -n;
  return n;
}

// The unused face whose outward normal is closest to `direction`.
std::string face_facing(const Structure& s, const Instance& inst, const Eigen::Vector3d& direction,
                        const std::string& source, const std::string& item) {
  std::string best;
  double best_dot = -2.0;
  for (const auto& [name, f] : inst.block->faces) {
    if (inst.used_faces.count(name)) continue;
    const double d = scene_face_normal(s, inst, f).dot(direction.normalized());
    if (d > best_dot) {
      best_dot = d;
      best = name;
    }
  }
  if (best.empty()) throw InputError(source, item, "block '" + inst.id + "' has no unused face left");
  return best;
}

}  // namespace

CharacterCounts count_structure(const Structure& s) {
  CharacterCounts c;
  c.nodes = s.num_nodes();
  for (const auto& e : s.elements) (e.kind == ElementKind::Strut ? c.struts : c.cables)++;
  for (int i = 0; i < s.num_nodes(); ++i) c.fixed_nodes += s.fixed[i] ? 1 : 0;
  c.mass = s.lumped_mass().sum();
  return c;
}

BuiltCharacter build_character(const nlohmann::json& j, const std::string& source, const BlockLibrary& library) {
  json_expect_header(j, "tensegrity-character", source);
  KeyChecker keys(source);
  keys.check(j, kCharacterKeys, "");
  BuiltCharacter out;
  Structure& s = out.structure;
  s.name = j.contains("name") ? json_string(j["name"], source, "name") : std::string("character");
  if (j.contains("gravity")) s.gravity = json_vector3(j["gravity"], source, "gravity");
  const double strut_density =
      j.contains("strut_density") ? json_mass(j["strut_density"], source, "strut_density") : 0.0;
  const double cable_density =
      j.contains("cable_density") ? json_mass(j["cable_density"], source, "cable_density") : 0.0;

  // Blocks.
  if (!j.contains("blocks") || !j["blocks"].is_array() || j["blocks"].empty())
    throw InputError(source, "blocks", "missing or not a non-empty array");
  std::map<std::string, Instance> instances;
  std::vector<std::string> order;
  for (std::size_t bi = 0; bi < j["blocks"].size(); ++bi) {
    const std::string item = "blocks[" + std::to_string(bi) + "]";
    const auto& jb = j["blocks"][bi];
    if (!jb.is_object()) throw InputError(source, item, "not an object");
    keys.check(jb, kBlockInstanceKeys, item);
    if (!jb.contains("id")) throw InputError(source, item + ".id", "missing");
    if (!jb.contains("type")) throw InputError(source, item + ".type", "missing");
    Instance inst;
    inst.id = json_string(jb["id"], source, item + ".id");
    if (inst.id.empty()) throw InputError(source, item + ".id", "empty");
    if (instances.count(inst.id)) throw InputError(source, item + ".id", "duplicate block id '" + inst.id + "'");
    inst.block = &library.get(json_string(jb["type"], source, item + ".type"), source, item + ".type");
    BlockTransform t;
    if (jb.contains("scale")) t.scale = json_positive(jb["scale"], source, item + ".scale");
    if (jb.contains("rotation_deg"))
      t.rotation = rotation_from_degrees(json_vector3(jb["rotation_deg"], source, item + ".rotation_deg"));
    if (jb.contains("translation")) t.translation = json_vector3(jb["translation"], source, item + ".translation");
    if (jb.contains("displacements")) {
      const auto& jd = jb["displacements"];
      if (!jd.is_array()) throw InputError(source, item + ".displacements", "must be an array");
      for (std::size_t k = 0; k < jd.size(); ++k) {
        const std::string it = item + ".displacements[" + std::to_string(k) + "]";
        keys.check(jd[k], kDisplacementKeys, it);
        if (!jd[k].is_object() || !jd[k].contains("node") || !jd[k].contains("by"))
          throw InputError(source, it, "must be {\"node\": index, \"by\": [dx, dy, dz]}");
        const int node = json_index(jd[k]["node"], inst.block->structure.num_nodes(), "node", source, it + ".node");
        t.displacements[node] = json_vector3(jd[k]["by"], source, it + ".by");
      }
    }
    const Eigen::Matrix3Xd x = instance_positions(*inst.block, t);
    for (int i = 0; i < x.cols(); ++i) {
      const int node = s.add_node(x.col(i));
      s.node_extra[node] = {{"block", inst.id}, {"block_node", i}};
      inst.node_map.push_back(node);
    }
    for (int e = 0; e < inst.block->structure.num_elements(); ++e) {
      const auto& el = inst.block->structure.elements[e];
      const int id = s.add_element(inst.node_map[el.a], inst.node_map[el.b], el.kind);
      s.element_extra[id] = {{"block", inst.id}, {"block_element", e}};
      const auto& ex = inst.block->structure.element_extra;
      if (e < static_cast<int>(ex.size()) && ex[e].contains("name")) s.element_extra[id]["name"] = ex[e]["name"];
      inst.element_ids.push_back(id);
    }
    if (jb.contains("ties")) {
      const int available = static_cast<int>(inst.block->ties.size());
      const int k = json_index(jb["ties"], available + 1, "tie count", source, item + ".ties");
      for (int t = 0; t < k; ++t) {
        const auto& tie = inst.block->ties[t];
        const int id = s.add_element(inst.node_map[tie[0]], inst.node_map[tie[1]], ElementKind::Cable);
        s.element_extra[id] = {{"block", inst.id}, {"tie", t}, {"name", "tie-" + std::to_string(t)}};
      }
    }
    order.push_back(inst.id);
    instances[inst.id] = std::move(inst);
    ++out.counts.blocks;
  }

  auto find_instance = [&](const nlohmann::json& v, const std::string& item) -> Instance& {
    const std::string id = json_string(v, source, item);
    auto it = instances.find(id);
    if (it == instances.end()) throw InputError(source, item, "unknown block id '" + id + "'");
    return it->second;
  };

  // Links.
  if (j.contains("links")) {
    if (!j["links"].is_array()) throw InputError(source, "links", "must be an array");
    std::set<std::string> link_ids;
    for (std::size_t li = 0; li < j["links"].size(); ++li) {
      const std::string item = "links[" + std::to_string(li) + "]";
      const auto& jl = j["links"][li];
      if (!jl.is_object()) throw InputError(source, item, "not an object");
      keys.check(jl, kLinkKeys, item);
      for (const char* side : {"a", "b"})
        if (jl.contains(side)) keys.check(jl[side], kLinkSideKeys, item + "." + side);
      const std::string id =
          jl.contains("id") ? json_string(jl["id"], source, item + ".id") : "link-" + std::to_string(li);
      if (!link_ids.insert(id).second) throw InputError(source, item + ".id", "duplicate link id '" + id + "'");
      const std::string type = jl.contains("type") ? json_string(jl["type"], source, item + ".type") : "";
      for (const char* side : {"a", "b"})
        if (!jl.contains(side) || !jl[side].is_object() || !jl[side].contains("block"))
          throw InputError(source, item + "." + side, "missing or without \"block\"");
      Instance& ia = find_instance(jl["a"]["block"], item + ".a.block");
      Instance& ib = find_instance(jl["b"]["block"], item + ".b.block");
      if (&ia == &ib) throw InputError(source, item, "a link joins two different blocks");
      LinkAddition added;
      if (type == "face") {
        auto pick_face = [&](Instance& inst, Instance& other, const nlohmann::json& js,
                             const std::string& it) -> std::array<int, 3> {
          std::string name;
          if (js.contains("face")) {
            name = json_string(js["face"], source, it + ".face");
            if (!inst.block->faces.count(name)) {
              std::string known;
              for (const auto& [n, f] : inst.block->faces) known += (known.empty() ? "" : ", ") + n;
              throw InputError(source, it + ".face", "block '" + inst.id + "' (" + inst.block->name +
                                                         ") has no face '" + name + "' (faces: " + known + ")");
            }
          } else if (js.contains("facing")) {
            name = face_facing(s, inst, json_vector3(js["facing"], source, it + ".facing"), source, it);
          } else {
            Instance& target = js.contains("toward") ? find_instance(js["toward"], it + ".toward") : other;
            name = face_facing(s, inst, instance_centroid(s, target) - instance_centroid(s, inst), source, it);
          }
          if (inst.used_faces.count(name))
            throw InputError(source, it + ".face", "face '" + name + "' of block '" + inst.id + "' is already linked");
          inst.used_faces.insert(name);
          const auto& f = inst.block->faces.at(name);
          return {inst.node_map[f[0]], inst.node_map[f[1]], inst.node_map[f[2]]};
        };
        const auto fa = pick_face(ia, ib, jl["a"], item + ".a");
        const auto fb = pick_face(ib, ia, jl["b"], item + ".b");
        const double depth = jl.contains("depth") ? json_positive(jl["depth"], source, item + ".depth") : 0.6;
        try {
          added = add_face_link(s, fa, fb, depth);
        } catch (const std::invalid_argument& e) {
          throw InputError(source, item, e.what());
        }
        ++out.counts.face_links;
      } else if (type == "edge") {
        auto pick_cable = [&](Instance& inst, const nlohmann::json& js, const std::string& it) {
          if (!js.contains("cable")) throw InputError(source, it + ".cable", "missing");
          const std::string cable = json_string(js["cable"], source, it + ".cable");
          if (!inst.block->cables.count(cable))
            throw InputError(source, it + ".cable", "block '" + inst.id + "' (" + inst.block->name +
                                                        ") has no cable named '" + cable + "'");
          const int e = inst.block->cables.at(cable);
          if (inst.element_ids[e] < 0)
            throw InputError(source, it + ".cable", "cable already removed by another edge link");
          return e;
        };
        const int ea = pick_cable(ia, jl["a"], item + ".a");
        const int eb = pick_cable(ib, jl["b"], item + ".b");
        const int sa = ia.element_ids[ea], sb = ib.element_ids[eb];
        try {
          added = add_edge_link(s, sa, sb);
        } catch (const std::invalid_argument& e) {
          throw InputError(source, item, e.what());
        }
        ia.element_ids[ea] = -1;
        ib.element_ids[eb] = -1;
        for (auto& [name, inst] : instances)
          for (int& id : inst.element_ids)
            if (id >= 0) id -= (id > sa) + (id > sb);
        ++out.counts.edge_links;
      } else {
        throw InputError(source, item + ".type", "must be \"face\" or \"edge\"");
      }
      for (int n : added.nodes) s.node_extra[n] = {{"link", id}};
      for (int n : added.merged_nodes) s.node_extra[n]["link"] = id;
      for (int e : added.elements) s.element_extra[e] = {{"link", id}};
    }
  }

  // Ground.
  if (j.contains("ground")) {
    if (!j["ground"].is_array()) throw InputError(source, "ground", "must be an array");
    for (std::size_t gi = 0; gi < j["ground"].size(); ++gi) {
      const std::string item = "ground[" + std::to_string(gi) + "]";
      const auto& jg = j["ground"][gi];
      if (jg.is_number()) {
        s.fixed[json_index(jg, s.num_nodes(), "node", source, item)] = true;
        continue;
      }
      keys.check(jg, kGroundKeys, item);
      if (!jg.is_object() || !jg.contains("block"))
        throw InputError(source, item, "must be a scene node index or {\"block\": id, \"lowest\": k | \"nodes\": [...]}");
      Instance& inst = find_instance(jg["block"], item + ".block");
      if (jg.contains("lowest")) {
        const int count = static_cast<int>(inst.node_map.size());
        const int k = json_index(jg["lowest"], count + 1, "node count", source, item + ".lowest");
        std::vector<int> nodes = inst.node_map;
        std::stable_sort(nodes.begin(), nodes.end(),
                         [&](int p, int q) { return s.positions(2, p) < s.positions(2, q); });
        for (int i = 0; i < k; ++i) s.fixed[nodes[i]] = true;
      } else if (jg.contains("nodes") && jg["nodes"].is_array()) {
        for (std::size_t k = 0; k < jg["nodes"].size(); ++k)
          s.fixed[inst.node_map[json_index(jg["nodes"][k], static_cast<int>(inst.node_map.size()), "node", source,
                                           item + ".nodes[" + std::to_string(k) + "]")]] = true;
      } else {
        throw InputError(source, item, "needs \"lowest\" or \"nodes\"");
      }
    }
  }

  // Masses from the linear densities at the built geometry.
  for (auto& e : s.elements) {
    const double len = (s.positions.col(e.b) - s.positions.col(e.a)).norm();
    e.mass = (e.kind == ElementKind::Strut ? strut_density : cable_density) * len;
  }
  s.extra["character"] = {{"blocks", out.counts.blocks},
                          {"face_links", out.counts.face_links},
                          {"edge_links", out.counts.edge_links}};
  validate(s, source);
  const CharacterCounts c = count_structure(s);
  out.counts.nodes = c.nodes;
  out.counts.struts = c.struts;
  out.counts.cables = c.cables;
  out.counts.fixed_nodes = c.fixed_nodes;
  out.counts.mass = c.mass;
  keys.report();
  return out;
}

BuiltCharacter build_character_file(const std::string& path, const std::string& library_override) {
  const nlohmann::json j = read_json_file(path);
  // The file's own header first: a file that is no character must be named
  // as the problem, not the block library it would have needed.
  json_expect_header(j, "tensegrity-character", path);
  namespace fs = std::filesystem;
  std::string dir = library_override;
  if (dir.empty()) {
    const fs::path base = fs::path(path).parent_path();
    std::string rel = "../blocks";
    if (j.is_object() && j.contains("block_library"))
      rel = json_string(j["block_library"], path, "block_library");
    dir = (base / rel).lexically_normal().string();
    if (dir.empty()) dir = ".";
  }
  const BlockLibrary library = BlockLibrary::load(dir);
  return build_character(j, path, library);
}

nlohmann::json make_chain_character(int n) {
  if (n < 2 || n > 200) throw std::invalid_argument("chain length must be within 2..200");
  using nlohmann::json;
  // Faces x+y+z+ and x-y-z- of the octahedron are parallel; turning (1,1,1)
  // onto +x lines them up along the chain.
  const Eigen::Matrix3d R =
      Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d(1, 1, 1).normalized(), Eigen::Vector3d::UnitX())
          .toRotationMatrix();
  const Eigen::Vector3d angles = R.eulerAngles(2, 1, 0);  // R = Rz(a0) Ry(a1) Rx(a2)
  const double scale = 0.05;                             // strut length 0.1 m
  const double spacing = scale * (2.0 * std::sqrt(0.75) + 0.6);
  json blocks = json::array(), links = json::array(), ground = json::array();
  for (int k = 0; k < n; ++k) {
    const std::string id = "block-" + std::to_string(k);
    blocks.push_back({{"id", id},
                      {"type", "icosahedron"},
                      {"scale", scale},
                      {"rotation_deg", {angles[2] * 180.0 / M_PI, angles[1] * 180.0 / M_PI, angles[0] * 180.0 / M_PI}},
                      {"translation", {k * spacing, 0.0, scale * 1.2}}});
    ground.push_back({{"block", id}, {"lowest", 3}});
    if (k > 0)
      links.push_back({{"id", "link-" + std::to_string(k - 1)},
                       {"type", "face"},
                       {"a", {{"block", "block-" + std::to_string(k - 1)}, {"face", "x+y+z+"}}},
                       {"b", {{"block", id}, {"face", "x-y-z-"}}}});
  }
  return {{"format", "tensegrity-character"},
          {"version", 1},
          {"name", "chain-" + std::to_string(n)},
          {"gravity", {0.0, 0.0, -9.81}},
          {"strut_density", 0.03},
          {"cable_density", 0.002},
          {"blocks", blocks},
          {"links", links},
          {"ground", ground}};
}

}  // namespace tensegrity
