#include "model/scene_io.hpp"

#include <string>
#include <utility>
#include <vector>

#include "model/errors.hpp"
#include "model/format_keys.hpp"
#include "model/json_io.hpp"
#include "model/json_text.hpp"

namespace tensegrity {

using nlohmann::json;

namespace {

std::string join(const std::string& prefix, const std::string& key) {
  return prefix.empty() ? key : prefix + "." + key;
}

std::string index_item(const std::string& prefix, std::size_t i) {
  return prefix + "[" + std::to_string(i) + "]";
}

}  // namespace

const std::vector<std::string_view>& scene_keys() {
  static const std::vector<std::string_view> keys = {"format", "version",  "name",     "description",
                                                     "gravity", "nodes",   "elements", "character"};
  return keys;
}

const std::vector<std::string_view>& scene_node_keys() {
  static const std::vector<std::string_view> keys = {"x", "fixed", "mass", "name", "block", "block_node", "link"};
  return keys;
}

const std::vector<std::string_view>& scene_element_keys() {
  static const std::vector<std::string_view> keys = {"kind", "nodes", "mass",     "name",         "block",
                                                     "block_element", "tie", "link", "material", "target_strain",
                                                     "ntrt_tags"};
  return keys;
}

Structure scene_from_json(const json& j, const std::string& source) {
  KeyChecker keys(source);
  Structure s = scene_from_json(j, source, keys);
  keys.report();
  return s;
}

Structure scene_from_json(const json& j, const std::string& source, KeyChecker& keys) {
  json_expect_header(j, "tensegrity-scene", source);
  keys.check(j, scene_keys(), "");
  Structure s;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& key = it.key();
    if (key == "format" || key == "version" || key == "nodes" || key == "elements") continue;
    if (key == "name")
      s.name = json_string(*it, source, "name");
    else if (key == "gravity")
      s.gravity = json_vector3(*it, source, "gravity");
    else
      s.extra[key] = *it;
  }

  const json& nodes = json_require_key(j, "nodes", source, "");
  if (!nodes.is_array()) throw InputError(source, "nodes", "expected an array of nodes, got " + json_describe(nodes));
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const std::string item = index_item("nodes", i);
    const json& node = nodes[i];
    if (!node.is_object()) throw InputError(source, item, "expected a node object, got " + json_describe(node));
    keys.check(node, scene_node_keys(), item);
    const Eigen::Vector3d x = json_vector3(json_require_key(node, "x", source, join(item, "x")), source, join(item, "x"));
    bool is_fixed = false;
    double mass = 0.0;
    json extra = json::object();
    for (auto it = node.begin(); it != node.end(); ++it) {
      if (it.key() == "x") continue;
      if (it.key() == "fixed") {
        if (!it->is_boolean())
          throw InputError(source, join(item, "fixed"), "expected true or false, got " + json_describe(*it));
        is_fixed = it->get<bool>();
      } else if (it.key() == "mass") {
        mass = json_mass(*it, source, join(item, "mass"));
      } else {
        extra[it.key()] = *it;
      }
    }
    s.add_node(x, is_fixed, mass);
    s.node_extra.back() = std::move(extra);
  }

  const json& elements = json_require_key(j, "elements", source, "");
  if (!elements.is_array())
    throw InputError(source, "elements", "expected an array of elements, got " + json_describe(elements));
  const int n = s.num_nodes();
  for (std::size_t e = 0; e < elements.size(); ++e) {
    const std::string item = index_item("elements", e);
    const json& element = elements[e];
    if (!element.is_object())
      throw InputError(source, item, "expected an element object, got " + json_describe(element));
    keys.check(element, scene_element_keys(), item);
    const std::string kind_text = json_string(json_require_key(element, "kind", source, join(item, "kind")), source,
                                              join(item, "kind"));
    ElementKind kind;
    if (kind_text == "strut")
      kind = ElementKind::Strut;
    else if (kind_text == "cable")
      kind = ElementKind::Cable;
    else
      throw InputError(source, join(item, "kind"),
                       "unknown kind " + json(kind_text).dump(-1, ' ', true) + " (expected \"strut\" or \"cable\")");
    const std::string ends_item = join(item, "nodes");
    const json& ends = json_require_key(element, "nodes", source, ends_item);
    if (!ends.is_array())
      throw InputError(source, ends_item, "expected an array of 2 node indices, got " + json_describe(ends));
    if (ends.size() != 2)
      throw InputError(source, ends_item, "expected exactly 2 node indices, got " + std::to_string(ends.size()));
    const int a = json_index(ends[0], n, "node", source, index_item(ends_item, 0));
    const int b = json_index(ends[1], n, "node", source, index_item(ends_item, 1));
    double mass = 0.0;
    json extra = json::object();
    for (auto it = element.begin(); it != element.end(); ++it) {
      if (it.key() == "kind" || it.key() == "nodes") continue;
      if (it.key() == "mass")
        mass = json_mass(*it, source, join(item, "mass"));
      else
        extra[it.key()] = *it;
    }
    s.add_element(a, b, kind, mass);
    s.element_extra.back() = std::move(extra);
  }
  validate(s, source);
  return s;
}

Structure read_scene_file(const std::string& path) { return scene_from_json(read_json_file(path), path); }

namespace {

json vector_json(const Eigen::Vector3d& x) { return json::array({x[0], x[1], x[2]}); }

// Unknown keys never overwrite the ones the model writes itself.
void merge_extra(json& target, const json& extra) {
  if (!extra.is_object()) return;
  for (auto it = extra.begin(); it != extra.end(); ++it)
    if (!target.contains(it.key())) target[it.key()] = *it;
}

}  // namespace

json scene_to_json(const Structure& s) {
  json j = json::object();
  j["format"] = "tensegrity-scene";
  j["version"] = 1;
  if (!s.name.empty()) j["name"] = s.name;
  if (s.has_gravity()) j["gravity"] = vector_json(s.gravity);
  json nodes = json::array();
  for (int i = 0; i < s.num_nodes(); ++i) {
    json node = json::object();
    node["x"] = vector_json(s.positions.col(i));
    if (i < static_cast<int>(s.fixed.size()) && s.fixed[i]) node["fixed"] = true;
    if (i < s.node_mass.size() && s.node_mass[i] != 0.0) node["mass"] = s.node_mass[i];
    if (i < static_cast<int>(s.node_extra.size())) merge_extra(node, s.node_extra[i]);
    nodes.push_back(std::move(node));
  }
  json elements = json::array();
  for (int e = 0; e < s.num_elements(); ++e) {
    const Element& el = s.elements[e];
    json element = json::object();
    element["kind"] = to_string(el.kind);
    element["nodes"] = json::array({el.a, el.b});
    if (el.mass != 0.0) element["mass"] = el.mass;
    if (e < static_cast<int>(s.element_extra.size())) merge_extra(element, s.element_extra[e]);
    elements.push_back(std::move(element));
  }
  j["nodes"] = std::move(nodes);
  j["elements"] = std::move(elements);
  merge_extra(j, s.extra);
  return j;
}

void write_scene_file(const Structure& s, const std::string& path) {
  write_text_file_atomically(path, to_json_text(scene_to_json(s)));
}

}  // namespace tensegrity
