#include "model/design.hpp"

#include <algorithm>
#include <cmath>

#include "model/errors.hpp"
#include "model/format_keys.hpp"
#include "model/json_io.hpp"
#include "model/json_text.hpp"
#include "model/known_keys.hpp"
#include "model/scene_io.hpp"

namespace tensegrity {

using nlohmann::json;

namespace {

// Keys of a design file that are not scene keys.
const char* const kDesignKeys[] = {"scene",        "solver",  "status",    "positions", "forces", "stats",
                                   "rest_lengths", "strains", "materials", "design"};

// Every top-level key of a design file: the scene's, the ones above, and the
// solution's optional ones.
const std::vector<std::string_view>& design_keys() {
  static const std::vector<std::string_view> keys = [] {
    std::vector<std::string_view> k = scene_keys();
    k.insert(k.end(), std::begin(kDesignKeys), std::end(kDesignKeys));
    for (const std::string_view key : solution_keys())
      if (std::find(k.begin(), k.end(), key) == k.end()) k.push_back(key);
    return k;
  }();
  return keys;
}

json numbers(const Eigen::VectorXd& v) {
  json a = json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(v[i]);
  return a;
}

Eigen::VectorXd per_element(const json& j, const char* key, int m, const std::string& source) {
  if (!j.contains(key)) throw InputError(source, key, "missing");
  const json& a = j.at(key);
  if (!a.is_array() || static_cast<int>(a.size()) != m)
    throw InputError(source, key, "expected an array with one number per element (" + std::to_string(m) + ")");
  Eigen::VectorXd v(m);
  for (int e = 0; e < m; ++e) v[e] = json_finite_number(a[e], source, std::string(key) + "[" + std::to_string(e) + "]");
  return v;
}

}  // namespace

std::vector<const CableMaterial*> Design::material_pointers() const {
  std::vector<const CableMaterial*> out(cable_material.size(), nullptr);
  for (std::size_t e = 0; e < cable_material.size(); ++e) {
    const auto it = materials.find(cable_material[e]);
    if (it != materials.end()) out[e] = &it->second;
  }
  return out;
}

json design_to_json(const Design& d) {
  Structure s = d.structure;
  for (int e = 0; e < s.num_elements(); ++e) {
    if (e >= static_cast<int>(s.element_extra.size())) s.element_extra.resize(e + 1, json::object());
    if (e < static_cast<int>(d.cable_material.size()) && !d.cable_material[e].empty())
      s.element_extra[e]["material"] = d.cable_material[e];
  }
  json j = scene_to_json(s);
  j["format"] = "tensegrity-design";
  j["version"] = 1;
  const json sol = solution_to_json(d.solution);
  for (auto it = sol.begin(); it != sol.end(); ++it)
    if (it.key() != "format" && it.key() != "version") j[it.key()] = *it;
  j["strains"] = numbers(d.strains);
  json mats = json::object();
  for (const auto& [name, m] : d.materials) mats[name] = material_to_json(m);
  j["materials"] = std::move(mats);
  j["design"] = d.info;
  return j;
}

void write_design_file(const Design& d, const std::string& path) {
  write_text_file_atomically(path, to_json_text(design_to_json(d)));
}

Design design_from_json(const json& j, const std::string& source) {
  json_expect_header(j, "tensegrity-design", source);
  KeyChecker keys(source);
  keys.check(j, design_keys(), "");
  if (j.contains("stats")) keys.check(j.at("stats"), solution_stats_keys(), "stats");
  json scene = j;
  for (const char* key : kDesignKeys) scene.erase(key);
  Design d;
  // The solution's optional keys ("message"...) belong to the solution part.
  for (const std::string_view key : solution_keys()) {
    const std::string k(key);
    const auto& scene_only = scene_keys();
    if (std::find(scene_only.begin(), scene_only.end(), key) != scene_only.end() || !scene.contains(k)) continue;
    d.solution.extra[k] = scene.at(k);
    scene.erase(k);
  }
  scene["format"] = "tensegrity-scene";
  d.structure = scene_from_json(scene, source, keys);
  const int n = d.structure.num_nodes(), m = d.structure.num_elements();

  Solution& sol = d.solution;
  sol.scene = j.contains("scene") ? json_string(j.at("scene"), source, "scene") : d.structure.name;
  sol.solver = j.contains("solver") ? json_string(j.at("solver"), source, "solver") : "";
  if (!j.contains("status")) throw InputError(source, "status", "missing");
  const auto status = status_from_string(json_string(j.at("status"), source, "status"));
  if (!status) throw InputError(source, "status", "unknown status");
  sol.status = *status;
  if (!j.contains("positions") || !j.at("positions").is_array() || static_cast<int>(j.at("positions").size()) != n)
    throw InputError(source, "positions", "expected one [x, y, z] per node (" + std::to_string(n) + ")");
  sol.positions.resize(3, n);
  for (int i = 0; i < n; ++i)
    sol.positions.col(i) = json_vector3(j.at("positions")[i], source, "positions[" + std::to_string(i) + "]");
  sol.forces = per_element(j, "forces", m, source);
  sol.rest_lengths = per_element(j, "rest_lengths", m, source);
  for (int e = 0; e < m; ++e)
    if (!((*sol.rest_lengths)[e] > 0.0))
      throw InputError(source, "rest_lengths[" + std::to_string(e) + "]", "must be > 0");
  d.strains = per_element(j, "strains", m, source);
  if (j.contains("stats") && j.at("stats").is_object()) {
    const json& st = j.at("stats");
    auto stat = [&](const char* key, double& out) {
      if (st.contains(key)) out = json_finite_number(st.at(key), source, std::string("stats.") + key);
    };
    double iterations = 0.0;
    stat("iterations", iterations);
    sol.stats.iterations = static_cast<int>(iterations);
    stat("seconds", sol.stats.seconds);
    stat("residual", sol.stats.residual);
    stat("relative_residual", sol.stats.relative_residual);
    stat("geometry_change", sol.stats.geometry_change);
  }

  if (!j.contains("materials") || !j.at("materials").is_object())
    throw InputError(source, "materials", "missing or not an object of material definitions");
  for (auto it = j.at("materials").begin(); it != j.at("materials").end(); ++it) {
    CableMaterial mat = material_from_json(*it, source + ": materials." + it.key(), keys, "materials." + it.key());
    d.materials[it.key()] = std::move(mat);
  }
  d.cable_material.assign(m, "");
  for (int e = 0; e < m; ++e) {
    if (d.structure.elements[e].kind != ElementKind::Cable) continue;
    const std::string item = "elements[" + std::to_string(e) + "].material";
    const json& extra = d.structure.element_extra[e];
    if (!extra.contains("material")) throw InputError(source, item, "missing: every cable needs a material");
    d.cable_material[e] = json_string(extra.at("material"), source, item);
    if (!d.materials.count(d.cable_material[e]))
      throw InputError(source, item, "material '" + d.cable_material[e] + "' is not defined in \"materials\"");
  }
  if (j.contains("design")) d.info = j.at("design");
  keys.report();
  return d;
}

Design read_design_file(const std::string& path) { return design_from_json(read_json_file(path), path); }

}  // namespace tensegrity
