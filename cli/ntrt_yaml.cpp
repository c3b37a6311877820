#include "cli/ntrt_yaml.hpp"

#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "model/errors.hpp"
#include "model/scene_io.hpp"

namespace tensegrity::cli {

namespace {

constexpr int kMaxNesting = 32;  // substructure depth; deeper is taken for a cycle
constexpr double kPi = 3.14159265358979323846;

// A structure in file coordinates while substructures are combined.
struct NtrtStructure {
  std::vector<std::string> names;
  std::vector<Eigen::Vector3d> points;
  struct Pair {
    int a, b;
    std::string tags;
  };
  std::vector<Pair> pairs;
  std::map<std::string, std::string> builder_class;  // tag -> class
  std::set<std::string> fixed;                        // node names from "# fixed:" lines

  Eigen::Vector3d centre() const {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const auto& p : points) c += p;
    return points.empty() ? c : Eigen::Vector3d(c / static_cast<double>(points.size()));
  }
};

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  std::istringstream in(s);
  while (std::getline(in, cur, sep))
    if (!cur.empty()) out.push_back(cur);
  return out;
}

Eigen::Vector3d vector3(const YAML::Node& n, const std::string& file, const std::string& item) {
  if (!n.IsSequence() || n.size() != 3) throw InputError(file, item, "expected [x, y, z]");
  Eigen::Vector3d v;
  for (int k = 0; k < 3; ++k) {
    try {
      v[k] = n[k].as<double>();
    } catch (const YAML::Exception&) {
      throw InputError(file, item, "expected three numbers");
    }
    if (!std::isfinite(v[k])) throw InputError(file, item, "not a finite number");
  }
  return v;
}

double number(const YAML::Node& n, const std::string& file, const std::string& item) {
  try {
    const double v = n.as<double>();
    if (std::isfinite(v)) return v;
  } catch (const YAML::Exception&) {
  }
  throw InputError(file, item, "expected a finite number");
}

// Index of node `name` below `prefix` ("" or "child."): the exact dotted name,
// else the one node of that subtree whose name ends in "." + name.
int resolve(const NtrtStructure& s, const std::string& prefix, const std::string& name, const std::string& file,
            const std::string& item) {
  const std::string full = prefix + name;
  int found = -1;
  for (std::size_t i = 0; i < s.names.size(); ++i)
    if (s.names[i] == full) return static_cast<int>(i);
  for (std::size_t i = 0; i < s.names.size(); ++i) {
    const std::string& n = s.names[i];
    if (n.size() > full.size() && n.compare(0, prefix.size(), prefix) == 0 &&
        n.compare(n.size() - name.size() - 1, name.size() + 1, "." + name) == 0) {
      if (found >= 0) throw InputError(file, item, "node '" + name + "' is ambiguous: name its substructure");
      found = static_cast<int>(i);
    }
  }
  if (found < 0) throw InputError(file, item, "unknown node '" + full + "'");
  return found;
}

std::pair<std::string, std::string> node_pair(const YAML::Node& p, const std::string& file, const std::string& item) {
  if (!p.IsSequence() || p.size() != 2 || !p[0].IsScalar() || !p[1].IsScalar())
    throw InputError(file, item, "expected a pair [node, node]");
  return {p[0].as<std::string>(), p[1].as<std::string>()};
}

void apply_transform(NtrtStructure& child, const YAML::Node& attrs, int series_index, const std::string& file,
                     const std::string& item) {
  if (const YAML::Node r = attrs["rotation"]) {
    const Eigen::Vector3d axis = vector3(r["axis"], file, item + ": rotation: axis");
    if (axis.norm() == 0) throw InputError(file, item + ": rotation: axis", "must not be zero");
    const double angle = number(r["angle"], file, item + ": rotation: angle") * kPi / 180.0;
    const Eigen::Vector3d ref = r["reference"] ? vector3(r["reference"], file, item + ": rotation: reference")
                                               : child.centre();
    const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
    for (auto& p : child.points) p = ref + R * (p - ref);
  }
  if (const YAML::Node sc = attrs["scale"]) {
    const double f = number(sc, file, item + ": scale");
    if (!(f > 0)) throw InputError(file, item + ": scale", "must be > 0");
    const Eigen::Vector3d c = child.centre();
    for (auto& p : child.points) p = c + f * (p - c);
  }
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();
  if (attrs["translation"]) shift += vector3(attrs["translation"], file, item + ": translation");
  if (attrs["offset"]) shift += series_index * vector3(attrs["offset"], file, item + ": offset");
  for (auto& p : child.points) p += shift;
}

void append_child(NtrtStructure& parent, const NtrtStructure& child, const std::string& child_name) {
  const int base = static_cast<int>(parent.names.size());
  for (std::size_t i = 0; i < child.names.size(); ++i) {
    parent.names.push_back(child_name + "." + child.names[i]);
    parent.points.push_back(child.points[i]);
  }
  for (const auto& p : child.pairs) parent.pairs.push_back({base + p.a, base + p.b, p.tags});
  for (const auto& [tag, cls] : child.builder_class) parent.builder_class.emplace(tag, cls);  // parent's win
  for (const auto& f : child.fixed) parent.fixed.insert(child_name + "." + f);
}

std::set<std::string> fixed_comment_names(const std::string& text) {
  std::set<std::string> names;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("# fixed:", 0) == 0)
      for (const auto& n : split(line.substr(8), ' ')) names.insert(n);
  return names;
}

NtrtStructure load(const std::string& path, int depth) {
  if (depth > kMaxNesting) throw InputError(path, "substructures", "nested too deep (a cycle?)");
  const std::string text = read_text_file(path);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(path, "line " + std::to_string(e.mark.line + 1), e.msg);
  }
  if (!root.IsMap()) throw InputError(path, "", "not an NTRT YAML structure (expected a mapping at the top)");
  NtrtStructure s;
  s.fixed = fixed_comment_names(text);
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (key != "nodes" && key != "pair_groups" && key != "builders" && key != "substructures" && key != "bond_groups")
      throw InputError(path, key, "unknown top-level key (NTRT knows nodes, pair_groups, builders, substructures, bond_groups)");
  }
  if (const YAML::Node b = root["builders"]) {
    if (!b.IsMap()) throw InputError(path, "builders", "expected a mapping");
    for (const auto& kv : b) {
      const std::string tag = kv.first.as<std::string>();
      if (!kv.second["class"]) throw InputError(path, "builders: " + tag, "missing class");
      s.builder_class[tag] = kv.second["class"].as<std::string>();
    }
  }
  if (const YAML::Node n = root["nodes"]) {
    if (!n.IsMap()) throw InputError(path, "nodes", "expected a mapping name: [x, y, z]");
    for (const auto& kv : n) {
      const std::string name = kv.first.as<std::string>();
      s.names.push_back(name);
      s.points.push_back(vector3(kv.second, path, "nodes: " + name));
    }
  }
  // Children: attributes may be spread over several keys naming them.
  std::vector<std::string> child_order;
  std::map<std::string, std::vector<std::pair<YAML::Node, int>>> child_attrs;  // (attributes, index in series)
  if (const YAML::Node subs = root["substructures"]) {
    if (!subs.IsMap()) throw InputError(path, "substructures", "expected a mapping");
    for (const auto& kv : subs) {
      const auto names = split(kv.first.as<std::string>(), '/');
      for (std::size_t k = 0; k < names.size(); ++k) {
        if (!child_attrs.count(names[k])) child_order.push_back(names[k]);
        child_attrs[names[k]].emplace_back(kv.second, static_cast<int>(k));
      }
    }
  }
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  for (const std::string& name : child_order) {
    std::string child_path;
    for (const auto& [attrs, k] : child_attrs[name])
      if (attrs["path"]) child_path = attrs["path"].as<std::string>();
    if (child_path.empty()) throw InputError(path, "substructures: " + name, "no path");
    const std::filesystem::path p(child_path);
    NtrtStructure child = load((p.is_absolute() ? p : dir / p).string(), depth + 1);
    // Rotations first, whatever their order in the file.
    for (const auto& [attrs, k] : child_attrs[name])
      if (attrs["rotation"]) {
        YAML::Node only;
        only["rotation"] = attrs["rotation"];
        apply_transform(child, only, k, path, "substructures: " + name);
      }
    for (const auto& [attrs, k] : child_attrs[name]) {
      YAML::Node rest;
      for (const char* a : {"scale", "translation", "offset"})
        if (attrs[a]) rest[a] = attrs[a];
      apply_transform(child, rest, k, path, "substructures: " + name);
    }
    append_child(s, child, name);
  }
  if (const YAML::Node groups = root["pair_groups"]) {
    if (!groups.IsMap()) throw InputError(path, "pair_groups", "expected a mapping tag: list of pairs");
    for (const auto& kv : groups) {
      const std::string tags = kv.first.as<std::string>(), item = "pair_groups: " + tags;
      if (!kv.second.IsSequence()) throw InputError(path, item, "expected a list of pairs");
      for (const auto& p : kv.second) {
        const auto [a, b] = node_pair(p, path, item);
        s.pairs.push_back({resolve(s, "", a, path, item), resolve(s, "", b, path, item), tags});
      }
    }
  }
  if (const YAML::Node bonds = root["bond_groups"]) {
    if (!bonds.IsMap()) throw InputError(path, "bond_groups", "expected a mapping");
    for (const auto& tag_kv : bonds) {
      const std::string tags = tag_kv.first.as<std::string>();
      if (!tag_kv.second.IsMap()) throw InputError(path, "bond_groups: " + tags, "expected a mapping");
      for (const auto& kv : tag_kv.second) {
        const std::string key = kv.first.as<std::string>(), item = "bond_groups: " + tags + ": " + key;
        auto parts = split(key, '/');
        if (parts.size() < 3) throw InputError(path, item, "expected child/child/.../node_node");
        const std::string type = parts.back();
        parts.pop_back();
        if (type != "node_node")
          throw InputError(path, item, "only node_node bonds are supported (" + type + " attaches to a string's middle)");
        if (!kv.second.IsSequence()) throw InputError(path, item, "expected a list of pairs");
        for (std::size_t k = 0; k + 1 < parts.size(); ++k)
          for (const auto& p : kv.second) {
            const auto [a, b] = node_pair(p, path, item);
            s.pairs.push_back(
                {resolve(s, parts[k] + ".", a, path, item), resolve(s, parts[k + 1] + ".", b, path, item), tags});
          }
      }
    }
  }
  return s;
}

// True for a strut (a rod builder), false for a cable; InputError when no builder matches.
bool is_strut(const NtrtStructure& s, const std::string& tags, const std::string& file) {
  for (const auto& tag : split(tags, ' ')) {
    const auto it = s.builder_class.find(tag);
    if (it != s.builder_class.end()) return it->second.find("Rod") != std::string::npos;
    if (tag == "rod") return true;
    if (tag == "string") return false;
  }
  throw InputError(file, "pair_groups: " + tags, "no builder for these tags (and neither 'rod' nor 'string')");
}

bool valid_ntrt_name(const std::string& n) {
  return !n.empty() && n.find_first_of(" ./:#[]{},\"'") == std::string::npos;
}

std::string number_text(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

Structure read_ntrt_yaml(const std::string& path, double length_scale) {
  const NtrtStructure s = load(path, 0);
  Structure out;
  out.name = std::filesystem::path(path).stem().string();
  const int n = static_cast<int>(s.points.size());
  out.positions.resize(3, n);
  out.fixed.assign(n, false);
  out.node_mass = Eigen::VectorXd::Zero(n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d& p = s.points[i];
    out.positions.col(i) = length_scale * Eigen::Vector3d(p.x(), -p.z(), p.y());
    out.node_extra.push_back({{"name", s.names[i]}});
    out.fixed[i] = s.fixed.count(s.names[i]) > 0;
  }
  for (const auto& p : s.pairs) {
    const int e = out.add_element(p.a, p.b, is_strut(s, p.tags, path) ? ElementKind::Strut : ElementKind::Cable);
    out.element_extra[e] = {{"ntrt_tags", p.tags}};
  }
  validate(out, path);
  return out;
}

std::string write_ntrt_yaml(const Structure& scene, const Eigen::Matrix3Xd& x, const NtrtExtras& extras,
                            double length_scale) {
  const int n = scene.num_nodes(), m = scene.num_elements();
  std::vector<std::string> names(n);
  std::set<std::string> used;
  for (int i = 0; i < n; ++i) {
    std::string name;
    if (i < static_cast<int>(scene.node_extra.size()) && scene.node_extra[i].contains("name") &&
        scene.node_extra[i]["name"].is_string())
      name = scene.node_extra[i]["name"].get<std::string>();
    for (char& c : name)
      if (c == '.') c = '_';
    if (!valid_ntrt_name(name) || used.count(name)) name = "n" + std::to_string(i);
    while (used.count(name)) name += "_";
    used.insert(name);
    names[i] = name;
  }
  const bool per_cable = extras.stiffness && extras.rest_lengths;
  std::vector<std::string> tag_order;
  std::map<std::string, std::vector<int>> groups;
  for (int e = 0; e < m; ++e) {
    const bool strut = scene.elements[e].kind == ElementKind::Strut;
    std::string tags = strut ? "rod" : per_cable ? "cable_" + std::to_string(e) : "string";
    const nlohmann::json extra = e < static_cast<int>(scene.element_extra.size()) ? scene.element_extra[e]
                                                                                   : nlohmann::json::object();
    for (const char* key : {"block", "link"})
      if (extra.contains(key) && extra[key].is_string() && valid_ntrt_name(extra[key].get<std::string>()) &&
          extra[key].get<std::string>() != "rod" && extra[key].get<std::string>() != "string") {
        tags += " " + extra[key].get<std::string>();
        break;
      }
    if (!groups.count(tags)) tag_order.push_back(tags);
    groups[tags].push_back(e);
  }
  std::ostringstream o;
  o << "# NTRT YAML structure '" << scene.name << "' written by tensegrity.\n"
    << "# Lengths in file units of " << number_text(length_scale) << " m; y is up (the scene's z).\n"
    << "# Forces in N; stiffness in N per file unit.\n";
  std::string fixed;
  for (int i = 0; i < n; ++i)
    if (scene.fixed[i]) fixed += " " + names[i];
  if (!fixed.empty()) o << "# fixed:" << fixed << "\n";
  o << "nodes:\n";
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p = x.col(i) / length_scale;
    o << "  " << names[i] << ": [" << number_text(p.x()) << ", " << number_text(p.z()) << ", "
      << number_text(-p.y()) << "]\n";
  }
  o << "pair_groups:\n";
  for (const std::string& tags : tag_order) {
    o << "  " << tags << ":\n";
    for (int e : groups[tags])
      o << "    - [" << names[scene.elements[e].a] << ", " << names[scene.elements[e].b] << "]\n";
  }
  o << "builders:\n  rod:\n    class: tgRodInfo\n    parameters:\n      radius: " << number_text(0.005 / length_scale)
    << "\n";
  if (!per_cable) {
    o << "  string:\n    class: tgBasicActuatorInfo\n";
    if (extras.forces) {
      double mean = 0;
      int cables = 0;
      for (int e = 0; e < m; ++e)
        if (scene.elements[e].kind == ElementKind::Cable) mean += (*extras.forces)[e], ++cables;
      if (cables > 0) o << "    parameters:\n      pretension: " << number_text(mean / cables) << "\n";
    }
  } else {
    for (int e = 0; e < m; ++e) {
      if (scene.elements[e].kind != ElementKind::Cable) continue;
      o << "  cable_" << e << ":\n    class: tgBasicActuatorInfo\n    parameters:\n      stiffness: "
        << number_text((*extras.stiffness)[e] * length_scale) << "\n";
      if (extras.forces) o << "      pretension: " << number_text((*extras.forces)[e]) << "\n";
      o << "      # rest length " << number_text((*extras.rest_lengths)[e] / length_scale) << " file units\n";
    }
  }
  return o.str();
}

}  // namespace tensegrity::cli
