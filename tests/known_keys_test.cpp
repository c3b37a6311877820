// Strict, extensible files: a near miss of a known key is an input error that
// names the typo and the intended key; any other unknown key is kept (and
// written back where the file is rewritten) and reported in one warning per
// file. Checked on the distance rule and on every file kind of model/.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "model/blocks.hpp"
#include "model/character.hpp"
#include "model/design.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/format_keys.hpp"
#include "model/known_keys.hpp"
#include "model/material.hpp"
#include "model/reference_scenes.hpp"
#include "model/scene_io.hpp"
#include "model/solution.hpp"

namespace tensegrity {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const std::string kSource = TENSEGRITY_SOURCE_DIR;

// Collects the warnings sent while it lives.
class WarningLog {
 public:
  WarningLog()
      : sink_([this](const std::string& file, const std::string& message) { lines.push_back(file + ": " + message); }) {}
  std::vector<std::string> lines;

 private:
  ScopedInputWarningSink sink_;
};

// The reason of the InputError that `parse` throws, with its item.
template <class Parse>
std::pair<std::string, std::string> item_and_reason(Parse parse) {
  try {
    parse();
  } catch (const InputError& e) {
    return {e.item(), e.reason()};
  }
  return {"(no error)", "(no error)"};
}

json three_node_scene() {
  return json::parse(R"({"format": "tensegrity-scene", "version": 1, "name": "keys",
    "gravity": [0, 0, -9.81],
    "nodes": [{"x": [0, 0, 0], "fixed": true}, {"x": [1, 0, 0.5], "mass": 0.1}, {"x": [0, 1, 0.5]}],
    "elements": [{"kind": "strut", "nodes": [0, 1]}, {"kind": "cable", "nodes": [1, 2]},
                 {"kind": "cable", "nodes": [0, 2]}]})");
}

TEST(EditDistance, CountsInsertionsDeletionsSubstitutionsAndSwaps) {
  EXPECT_EQ(edit_distance("fixd", "fixed"), 1u);
  EXPECT_EQ(edit_distance("gravty", "gravity"), 1u);
  EXPECT_EQ(edit_distance("mas", "mass"), 1u);
  EXPECT_EQ(edit_distance("scal", "scale"), 1u);
  EXPECT_EQ(edit_distance("fxied", "fixed"), 1u);  // one swap of neighbours
  EXPECT_EQ(edit_distance("kitten", "sitting"), 3u);
  EXPECT_EQ(edit_distance("", "abc"), 3u);
  EXPECT_EQ(edit_distance("mass", "mass"), 0u);
  // Optimal string alignment: "ca" -> "ac" -> "abc" may not edit the swapped pair again.
  EXPECT_EQ(edit_distance("ca", "abc"), 3u);
  EXPECT_EQ(edit_distance("color", "block"), 4u);
}

TEST(EditDistance, ShortKeysAllowOneEditLongerOnesTwo) {
  EXPECT_EQ(typo_distance_limit("mas", "mass"), 1u);
  EXPECT_EQ(typo_distance_limit("y", "x"), 1u);
  EXPECT_EQ(typo_distance_limit("fixd", "fixed"), 2u);
  const std::vector<std::string_view> node = {"x", "fixed", "mass"};
  EXPECT_EQ(misspelled_key("fixd", node), "fixed");
  EXPECT_EQ(misspelled_key("fxd", node), "");         // 2 edits, and 3 letters allow one
  EXPECT_EQ(misspelled_key("fiexd", node), "fixed");  // 2 edits on 5 letters
  EXPECT_EQ(misspelled_key("ms", node), "");          // 2 edits from "mass", short: no
  EXPECT_EQ(misspelled_key("xy", node), "x");
  EXPECT_EQ(misspelled_key("id", node), "");          // 2 edits from "x"
  EXPECT_EQ(misspelled_key("color", node), "");
  EXPECT_EQ(misspelled_key("fixed", node), "");       // a known key is never a typo
  // A key that is known is never an error even when it is near another one.
  const std::vector<std::string_view> near_pair = {"block", "blocks"};
  EXPECT_EQ(misspelled_key("block", near_pair), "");
  EXPECT_EQ(misspelled_key("blockss", near_pair), "blocks");  // the closest wins
  EXPECT_EQ(misspelled_key("blocs", near_pair), "block");     // on a tie, the first listed
}

TEST(KeyChecker, MessageNamesTypoAndIntendedKeyAndKeepsTheRest) {
  KeyChecker keys("f.json");
  keys.check(json{{"x", 1}, {"color", "red"}}, {"x", "fixed", "mass"}, "nodes[3]");
  keys.check(json{{"x", 1}, {"color", "red"}}, {"x", "fixed", "mass"}, "nodes[3]");  // once only
  keys.check(json{{"name2", 1}}, {"nodes", "elements"}, "");
  EXPECT_EQ(keys.unknown_keys(), (std::vector<std::string>{"nodes[3].color", "name2"}));
  EXPECT_EQ(unknown_keys_message(keys.unknown_keys()), "unknown keys kept: nodes[3].color, name2");
  try {
    keys.check(json{{"fixd", true}}, {"x", "fixed", "mass"}, "nodes[1]");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "f.json: nodes[1]: unknown key 'fixd' (did you mean 'fixed'?)");
  }
}

TEST(KeyChecker, LongListsAreCutAfterTenKeys) {
  std::vector<std::string> many;
  for (int k = 0; k < 12; ++k) many.push_back("nodes[" + std::to_string(k) + "].color");
  const std::string message = unknown_keys_message(many);
  EXPECT_NE(message.find("nodes[9].color and 2 more"), std::string::npos) << message;
  EXPECT_EQ(message.find("nodes[10]"), std::string::npos) << message;
}

TEST(KeyChecker, WarningsGoToTheInnermostSinkOnly) {
  WarningLog outer;
  {
    WarningLog inner;
    KeyChecker keys("a.json");
    keys.check(json{{"color", 1}}, {"x"}, "");
    keys.report();
    EXPECT_EQ(inner.lines, std::vector<std::string>{"a.json: unknown keys kept: color"});
  }
  EXPECT_TRUE(outer.lines.empty());
  KeyChecker none("b.json");
  none.report();  // nothing unknown: no line
  EXPECT_TRUE(outer.lines.empty());
}

TEST(SceneKeys, TyposAreErrorsNamingTheIntendedKey) {
  struct Case {
    const char* pointer;  // where the typo goes
    const char* key;
    std::string item, reason;
  };
  const std::vector<Case> cases = {
      {"/nodes/2", "fixd", "nodes[2]", "unknown key 'fixd' (did you mean 'fixed'?)"},
      {"", "gravty", "", "unknown key 'gravty' (did you mean 'gravity'?)"},
      {"/nodes/1", "mas", "nodes[1]", "unknown key 'mas' (did you mean 'mass'?)"},
      {"/elements/1", "mass_", "elements[1]", "unknown key 'mass_' (did you mean 'mass'?)"},
      {"/elements/0", "Kind", "elements[0]", "unknown key 'Kind' (did you mean 'kind'?)"},
      {"", "nmae", "", "unknown key 'nmae' (did you mean 'name'?)"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.key);
    json j = three_node_scene();
    j[json::json_pointer(c.pointer)][c.key] = true;
    WarningLog log;
    const auto [item, reason] = item_and_reason([&] { scene_from_json(j, "s.json"); });
    EXPECT_EQ(item, c.item);
    EXPECT_EQ(reason, c.reason);
    EXPECT_TRUE(log.lines.empty()) << "a rejected file gives no warning";
  }
}

TEST(SceneKeys, DistantKeysAreKeptWrittenBackAndReportedOnce) {
  json j = three_node_scene();
  j["nodes"][1]["color"] = "red";
  j["elements"][2]["colour"] = "blue";
  j["comment"] = {{"by", "hand"}};
  j["nodes"][0]["block"] = "body";  // a key the program writes itself: no warning
  WarningLog log;
  const Structure s = scene_from_json(j, "s.json");
  ASSERT_EQ(log.lines.size(), 1u);
  EXPECT_EQ(log.lines[0], "s.json: unknown keys kept: comment, nodes[1].color, elements[2].colour");
  const json back = scene_to_json(s);
  EXPECT_EQ(back["nodes"][1]["color"], "red");
  EXPECT_EQ(back["elements"][2]["colour"], "blue");
  EXPECT_EQ(back["comment"]["by"], "hand");
  EXPECT_EQ(back["nodes"][0]["block"], "body");
}

TEST(SolutionKeys, TyposAreErrorsAndOtherKeysAreKept) {
  const Structure scene = scene_from_json(three_node_scene(), "s.json");
  Solution sol;
  sol.scene = "keys";
  sol.solver = "test";
  sol.status = Status::Converged;
  sol.positions = scene.positions;
  sol.forces = Eigen::VectorXd::Ones(3);
  const fs::path dir = fs::temp_directory_path() / ("tensegrity-keys-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "a.solution.json").string();
  auto write = [&](const json& j) { write_text_file_atomically(path, j.dump()); };

  json j = solution_to_json(sol);
  j["forcs"] = j["forces"];
  write(j);
  EXPECT_EQ(item_and_reason([&] { read_solution_file(path, scene); }),
            (std::pair<std::string, std::string>{"", "unknown key 'forcs' (did you mean 'forces'?)"}));
  j = solution_to_json(sol);
  j["stats"]["residul"] = 0.0;
  write(j);
  EXPECT_EQ(item_and_reason([&] { read_solution_file(path, scene); }),
            (std::pair<std::string, std::string>{"stats", "unknown key 'residul' (did you mean 'residual'?)"}));

  j = solution_to_json(sol);
  j["machine"] = "lab";
  j["message"] = "a backend's words";  // written by the program: known
  write(j);
  WarningLog log;
  const Solution back = read_solution_file(path, scene);
  EXPECT_EQ(log.lines, std::vector<std::string>{path + ": unknown keys kept: machine"});
  EXPECT_EQ(back.extra.at("machine"), "lab");
  EXPECT_EQ(solution_to_json(back).at("message"), "a backend's words");
  fs::remove_all(dir);
}

// Every key `build` writes into a scene is one the scene reader knows: a built
// character read back gives no warning and keeps its block ties.
TEST(CharacterKeys, BuiltCharactersReadBackWithoutWarnings) {
  const BlockLibrary library = BlockLibrary::load(kSource + "/data/blocks");
  for (const std::string name : {"duck", "scorpion", "puppy"}) {
    const std::string path = kSource + "/data/characters/" + name + ".character.json";
    const Structure built = build_character(read_json_file(path), path, library).structure;
    int ties = 0;
    for (const auto& extra : built.element_extra) ties += extra.contains("tie") ? 1 : 0;
    if (name != "puppy") {
      EXPECT_GT(ties, 0) << name << ": its braced blocks carry ties";
    }
    WarningLog log;
    const Structure read_back = scene_from_json(scene_to_json(built), name + ".scene.json");
    EXPECT_TRUE(log.lines.empty()) << name << ": " << (log.lines.empty() ? "" : log.lines[0]);
    EXPECT_EQ(read_back.num_elements(), built.num_elements()) << name;
  }
}

TEST(CharacterKeys, ScalIsAnErrorAndColorIsKept) {
  const json duck = read_json_file(kSource + "/data/characters/duck.character.json");
  const BlockLibrary library = BlockLibrary::load(kSource + "/data/blocks");
  json j = duck;
  j["blocks"][4]["scal"] = j["blocks"][4]["scale"];
  j["blocks"][4].erase("scale");
  EXPECT_EQ(item_and_reason([&] { build_character(j, "duck.json", library); }),
            (std::pair<std::string, std::string>{"blocks[4]", "unknown key 'scal' (did you mean 'scale'?)"}));
  for (const auto& [pointer, key, item, intended] :
       std::vector<std::tuple<std::string, std::string, std::string, std::string>>{
           {"/links/0/a", "blok", "links[0].a", "block"},
           {"/links/1", "dept", "links[1]", "depth"},
           {"/ground/0", "lowst", "ground[0]", "lowest"},
           {"/blocks/0/displacements/0", "bye", "blocks[0].displacements[0]", "by"},
           {"", "strut_densty", "", "strut_density"}}) {
    json k = duck;
    k[json::json_pointer(pointer)][key] = 1;
    EXPECT_EQ(item_and_reason([&] { build_character(k, "duck.json", library); }),
              (std::pair<std::string, std::string>{
                  item, "unknown key '" + key + "' (did you mean '" + intended + "'?)"}));
  }

  json kept = duck;
  kept["blocks"][1]["color"] = "orange";
  WarningLog log;
  const BuiltCharacter built = build_character(kept, "duck.json", library);
  EXPECT_EQ(log.lines, std::vector<std::string>{"duck.json: unknown keys kept: blocks[1].color"});
  // The built duck weighs what the file says (scale 0.045 on the head, not 1).
  EXPECT_NEAR(built.counts.mass, build_character(duck, "duck.json", library).counts.mass, 1e-15);
}

TEST(BlockKeys, TyposAreErrorsAndUnknownKeysAreReported) {
  const json prism = block_to_json(make_prism_block(3));
  for (const auto& [pointer, key, item, intended] :
       std::vector<std::tuple<std::string, std::string, std::string, std::string>>{
           {"/elements/0", "forse", "elements[0]", "force"},
           {"/faces/0", "normals", "faces[0]", "normal"},
           {"/counts", "strts", "counts", "struts"},
           {"", "sorce", "", "source"}}) {
    json j = prism;
    j[json::json_pointer(pointer)][key] = 1;
    EXPECT_EQ(item_and_reason([&] { block_from_json(j, "p.block.json"); }),
              (std::pair<std::string, std::string>{
                  item, "unknown key '" + key + "' (did you mean '" + intended + "'?)"}));
  }
  json j = prism;
  j["comment"] = "measured by hand";
  WarningLog log;
  const Block b = block_from_json(j, "p.block.json");
  EXPECT_EQ(log.lines, std::vector<std::string>{"p.block.json: unknown keys kept: comment"});
  EXPECT_EQ(b.num_struts(), 3);
}

TEST(MaterialKeys, TyposAreErrorsAndUnknownKeysAreWrittenBack) {
  const json cord = read_json_file(kSource + "/data/materials/elastic-cord-1mm.json");
  json j = cord;
  j["diamter"] = j["diameter"];
  EXPECT_EQ(item_and_reason([&] { material_from_json(j, "m.json"); }),
            (std::pair<std::string, std::string>{"", "unknown key 'diamter' (did you mean 'diameter'?)"}));
  j = cord;
  j["supplier"] = "a shop";
  j["fit"]["anything"] = "free-form provenance";  // "fit" is not checked inside
  WarningLog log;
  const CableMaterial m = material_from_json(j, "m.json");
  EXPECT_EQ(log.lines, std::vector<std::string>{"m.json: unknown keys kept: supplier"});
  EXPECT_EQ(material_to_json(m).at("supplier"), "a shop");
  EXPECT_EQ(material_to_json(m).at("fit").at("anything"), "free-form provenance");
}

TEST(MaterialKeys, AMisspelledKeyLineOfMeasuredPointsIsAnError) {
  const fs::path dir = fs::temp_directory_path() / ("tensegrity-points-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "cord.points.csv").string();
  const std::string points = "strain,force\n0,0\n0.1,1\n0.2,2\n0.3,3\n0.4,4\n0.5,5\n";
  write_text_file_atomically(path, "# name = cord\n# diamter = 0.001\n" + points);
  EXPECT_EQ(item_and_reason([&] { read_points_csv(path); }),
            (std::pair<std::string, std::string>{"line 2", "unknown key 'diamter' (did you mean 'diameter'?)"}));
  // Other comment lines stay comments, whatever they hold.
  write_text_file_atomically(path, "# diameter = 0.001\n# made up: F = 10 eps\n# colour = red\n" + points);
  const MeasuredPoints read = read_points_csv(path);
  EXPECT_EQ(read.diameter, 0.001);
  EXPECT_EQ(read.points.size(), 6u);
  fs::remove_all(dir);
}

Design small_design() {
  Design d;
  PrismParameters p;
  d.structure = make_regular_prism(p);
  d.structure.fixed[0] = true;
  const int m = d.structure.num_elements();
  d.solution.scene = d.structure.name;
  d.solution.solver = "test";
  d.solution.status = Status::Converged;
  d.solution.positions = d.structure.positions;
  d.solution.forces = Eigen::VectorXd::Ones(m);
  d.solution.rest_lengths = Eigen::VectorXd::Constant(m, 0.5);
  d.strains = Eigen::VectorXd::Zero(m);
  d.materials["elastic-cord-1mm"] = read_material_file(kSource + "/data/materials/elastic-cord-1mm.json");
  d.cable_material.assign(m, "");
  for (int e = 0; e < m; ++e)
    if (d.structure.elements[e].kind == ElementKind::Cable) d.cable_material[e] = "elastic-cord-1mm";
  return d;
}

TEST(DesignKeys, TyposAnywhereAreErrorsAndOtherKeysAreKeptOnce) {
  const json design = design_to_json(small_design());
  for (const auto& [pointer, key, item, intended] :
       std::vector<std::tuple<std::string, std::string, std::string, std::string>>{
           {"", "strans", "", "strains"},
           {"", "gravty", "", "gravity"},
           {"/nodes/1", "fixd", "nodes[1]", "fixed"},
           {"/elements/3", "materal", "elements[3]", "material"},
           {"/stats", "secnds", "stats", "seconds"},
           {"/materials/elastic-cord-1mm", "diamter", "materials.elastic-cord-1mm", "diameter"}}) {
    json j = design;
    j[json::json_pointer(pointer)][key] = 1;
    EXPECT_EQ(item_and_reason([&] { design_from_json(j, "d.json"); }),
              (std::pair<std::string, std::string>{
                  item, "unknown key '" + key + "' (did you mean '" + intended + "'?)"}));
  }
  json j = design;
  j["comment"] = "first try";
  j["message"] = "from the solver";
  j["nodes"][2]["color"] = "red";
  j["materials"]["elastic-cord-1mm"]["supplier"] = "a shop";
  WarningLog log;
  const Design d = design_from_json(j, "d.json");
  EXPECT_EQ(log.lines, std::vector<std::string>{
                           "d.json: unknown keys kept: comment, nodes[2].color, materials.elastic-cord-1mm.supplier"});
  const json back = design_to_json(d);
  EXPECT_EQ(back.at("comment"), "first try");
  EXPECT_EQ(back.at("message"), "from the solver");
  EXPECT_EQ(back.at("nodes")[2].at("color"), "red");
  EXPECT_EQ(back.at("materials").at("elastic-cord-1mm").at("supplier"), "a shop");
}

TEST(ShippedFiles, HaveNoUnknownKeys) {
  WarningLog log;
  for (const auto& entry : fs::recursive_directory_iterator(kSource + "/data")) {
    const std::string path = entry.path().string();
    if (path.ends_with(".scene.json")) read_scene_file(path);
    if (path.ends_with(".block.json")) read_block_file(path);
    if (path.ends_with(".character.json")) build_character_file(path);
    if (entry.path().parent_path().filename() == "materials" && entry.path().extension() == ".json")
      read_material_file(path);
  }
  EXPECT_TRUE(log.lines.empty()) << log.lines.front();
}

}  // namespace
}  // namespace tensegrity
