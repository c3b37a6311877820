// `tensegrity design` and `tensegrity fit-material` through the real program:
// files and counts on success, the design file alone feeding relax and
// simulate, bad input (exit 2, one line, no file), a design that cannot be
// built (exit 1, the cable named, no file) and the designed-versus-naive
// comparison of a character.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <regex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "model/design.hpp"
#include "model/material.hpp"
#include "model/reference_scenes.hpp"
#include "model/scene_io.hpp"
#include "process_runner.hpp"
#include "simulation_fixtures.hpp"

namespace tensegrity {
namespace {

using testing::is_one_line;
using testing::ProgramRun;
using testing::ScratchDir;

const std::string kSource = TENSEGRITY_SOURCE_DIR;
const std::string kPuppy = kSource + "/data/characters/puppy.character.json";
const std::string kPoints1mm = kSource + "/data/materials/elastic-cord-1mm.points.csv";

std::vector<std::vector<std::string>> read_csv(const std::string& path) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(testing::read_text(path));
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> fields;
    std::string field;
    std::istringstream l(line);
    while (std::getline(l, field, ',')) fields.push_back(field);
    if (!line.empty() && line.back() == ',') fields.push_back("");
    rows.push_back(fields);
  }
  return rows;
}

// A prism standing on its fixed bottom ring under gravity (no block ids).
std::string gravity_prism(const ScratchDir& dir, int n = 4) {
  return testing::gravity_prism_scene(dir.work().string(), n, "prism.scene.json");
}

void expect_bad_input(const ScratchDir& dir, const std::vector<std::string>& args, const std::string& names,
                      const std::vector<std::string>& expected_files) {
  const ProgramRun r = dir.run(args);
  EXPECT_EQ(r.exit_status, 2) << r.err;
  EXPECT_TRUE(is_one_line(r.err)) << r.err;
  EXPECT_NE(r.err.find(names), std::string::npos) << "does not name '" << names << "': " << r.err;
  EXPECT_EQ(dir.work_files(), expected_files) << r.err;
}

TEST(CliDesign, CharacterGivesTheDesignAndTheSheetInAssemblyOrder) {
  ScratchDir dir("cli-design");
  const std::string design = dir.file("puppy.design.json"), sheet = dir.file("puppy.csv");
  const ProgramRun r =
      dir.run({"design", kPuppy, "--material", "elastic-cord-2mm", "--out", design, "--sheet", sheet});
  ASSERT_EQ(r.exit_status, 0) << r.err;
  const Design d = read_design_file(design);
  ASSERT_EQ(d.structure.num_elements(), 291);
  EXPECT_EQ(d.solution.status, Status::Converged);
  EXPECT_EQ(d.info.at("mode"), "stiffness");
  EXPECT_LT(d.info.at("round_trip_relative_error").get<double>(), 1e-9);

  const auto rows = read_csv(sheet);
  ASSERT_EQ(rows.size(), 1u + 291u + 2u);  // header, every element, strut total, one cable total
  EXPECT_EQ(rows[0][0], "group_kind");
  ASSERT_EQ(rows[0].size(), 13u);
  int struts = 0, cables = 0;
  double cable_rest = 0.0;
  bool seen_link = false;
  std::map<int, int> element_rows;
  for (std::size_t k = 1; k + 2 < rows.size(); ++k) {
    const auto& row = rows[k];
    ASSERT_EQ(row.size(), 13u) << k;
    // Blocks first, then links.
    if (row[0] == "link") seen_link = true;
    else EXPECT_EQ(row[0], "block") << k;
    if (seen_link) {
      EXPECT_EQ(row[0], "link") << k;
    }
    const int e = std::stoi(row[2]);
    ++element_rows[e];
    // Millimetres to 0.1 mm, forces to 3 significant digits, element names.
    const double rest = std::stod(row[9]) / 1000.0;
    EXPECT_NEAR(rest, (*d.solution.rest_lengths)[e], 0.51e-4) << k;
    EXPECT_NEAR(std::stod(row[10]), d.solution.forces[e], 5e-3 * std::abs(d.solution.forces[e])) << k;
    EXPECT_EQ(row[3].rfind(row[1] + ".", 0), 0u) << row[3];  // "block.strut-0", "link.cable-2"
    if (row[4] == "strut") ++struts;
    else ++cables, cable_rest += rest;
  }
  EXPECT_TRUE(seen_link);
  EXPECT_EQ(element_rows.size(), 291u);  // every element exactly once
  EXPECT_EQ(struts, 51);
  EXPECT_EQ(cables, 240);
  const auto& strut_total = rows[rows.size() - 2];
  const auto& cable_total = rows.back();
  EXPECT_EQ(strut_total[0], "total");
  EXPECT_EQ(strut_total[4], "strut");
  EXPECT_EQ(strut_total[12], "51");
  EXPECT_EQ(cable_total[4], "cable");
  EXPECT_EQ(cable_total[7], "elastic-cord-2mm");
  EXPECT_EQ(cable_total[12], "240");
  EXPECT_NEAR(std::stod(cable_total[9]) / 1000.0, cable_rest, 0.5e-4 * 240);
  // The printable cut list beside the sheet names every element.
  const std::string cut_list = testing::read_text(dir.file("puppy.cutlist.svg"));
  EXPECT_NE(cut_list.find("<text"), std::string::npos);
  EXPECT_EQ(std::count(cut_list.begin(), cut_list.end(), '\n') > 291, true);
  // And on A4 pages as PDF: 291 element rows, 17 group headings with their
  // gaps and the totals, 18 px a row on 1123 px pages (67 px for the title,
  // 50 px bottom margin, about 56 rows a page), fill six pages; every page
  // is A4 (595.5 x 842.25 pt).
  const std::string pdf = testing::read_text(dir.file("puppy.cutlist.pdf"));
  EXPECT_EQ(pdf.rfind("%PDF-", 0), 0u);
  const std::regex page(R"(/Type /Page[^s])"), a4(R"(/MediaBox \[ 0 0 595\.5 842\.25 \])");
  const auto pages = std::distance(std::sregex_iterator(pdf.begin(), pdf.end(), page), std::sregex_iterator());
  const auto a4_pages = std::distance(std::sregex_iterator(pdf.begin(), pdf.end(), a4), std::sregex_iterator());
  EXPECT_EQ(pages, 6);
  EXPECT_EQ(a4_pages, pages);

  // relax and simulate need nothing but the design file.
  const ProgramRun relax = dir.run({"relax", design, "--out", dir.file("relaxed.solution.json")});
  EXPECT_EQ(relax.exit_status, 0) << relax.err;
  const nlohmann::json relaxed = nlohmann::json::parse(testing::read_text(dir.file("relaxed.solution.json")));
  EXPECT_LT(relaxed.at("relative_max_displacement").get<double>(), 1e-9);
  const ProgramRun sim = dir.run(
      {"simulate", design, "--dt", "0.01", "--steps", "20", "--out", dir.file("frames.jsonl"), "--no-vtk"});
  EXPECT_EQ(sim.exit_status, 0) << sim.err;
  std::ifstream frames(dir.file("frames.jsonl"));
  int lines = 0;
  for (std::string line; std::getline(frames, line);) ++lines;
  EXPECT_GE(lines, 20);
}

TEST(CliDesign, CompareNaiveRecordsThatOnlyTheDesignHoldsItsShape) {
  ScratchDir dir("cli-design-naive");
  const std::string design = dir.file("puppy.design.json");
  const ProgramRun r = dir.run({"design", kPuppy, "--material", "elastic-cord-2mm", "--out", design,
                                "--naive-fractions", "0.5:1:51"});
  ASSERT_EQ(r.exit_status, 0) << r.err;
  EXPECT_NE(r.err.find("best naive fraction"), std::string::npos) << r.err;
  const nlohmann::json j = nlohmann::json::parse(testing::read_text(design));
  const nlohmann::json& c = j.at("design").at("naive_comparison");
  EXPECT_EQ(c.at("format"), "tensegrity-naive-comparison");
  EXPECT_EQ(c.at("version"), 1);
  EXPECT_EQ(c.at("method"), "relax");
  EXPECT_EQ(c.at("designed").at("status"), "converged");
  EXPECT_LT(c.at("designed").at("relative_max_displacement").get<double>(), 1e-9);
  ASSERT_EQ(c.at("naive").size(), 51u);
  double best = INFINITY;
  for (const auto& p : c.at("naive"))
    if (p.at("in_material_range").get<bool>() && p.at("status") == "converged")
      best = std::min(best, p.at("relative_max_displacement").get<double>());
  // Measured: 0.092 of the size (53 mm) at fraction 0.84.
  EXPECT_GT(best, 0.05);
  EXPECT_LT(best, 1.0);
}

TEST(CliDesign, BadInputIsRejectedWithOneLineAndNoFile) {
  ScratchDir dir("cli-design-bad");
  const std::string scene = gravity_prism(dir);
  const std::vector<std::string> only_scene = {"prism.scene.json"};
  const std::string out = dir.file("out.design.json"), sheet = dir.file("out.csv");
  expect_bad_input(dir, {"design", scene, "--material", "no-such-cord", "--out", out, "--sheet", sheet},
                   "no-such-cord", only_scene);
  expect_bad_input(dir, {"design", scene, "--material", "elastic-cord-2mm", "--strain", "1.5", "--out", out},
                   "--strain", only_scene);
  expect_bad_input(dir, {"design", scene, "--material", "elastic-cord-2mm", "--strain", "nan", "--out", out},
                   "--strain", only_scene);
  // Fraction 0.3 asks for strain 2.33, beyond what the cord was measured at.
  expect_bad_input(dir, {"design", scene, "--naive-fraction", "0.3", "--out", out, "--sheet", sheet},
                   "--naive-fraction", only_scene);
  expect_bad_input(dir, {"design", scene, "--naive-fractions", "0.5:0.9", "--out", out}, "--naive-fractions",
                   only_scene);
  expect_bad_input(dir, {"design", scene, "--naive-fraction", "0.8", "--compare-naive", "--out", out},
                   "--compare-naive", only_scene);
  expect_bad_input(dir, {"design", scene, "--settle", "wobble", "--compare-naive", "--out", out}, "--settle",
                   only_scene);
  expect_bad_input(dir, {"design", scene, "--out", dir.file("missing/out.design.json")}, "missing", only_scene);

  // fit-material: a broken CSV names the file and the line.
  const std::string csv = dir.file("broken.points.csv");
  std::ofstream(csv) << "# diameter = 0.001\n# linear_density = 0.001\nstrain,force\n0,0\n0.1,abc\n";
  expect_bad_input(dir, {"fit-material", csv, "--out", out}, "broken.points.csv",
                   {"broken.points.csv", "prism.scene.json"});
  // A falling curve is refused, not fitted.
  const std::string falling = dir.file("falling.points.csv");
  {
    std::ofstream f(falling);
    f << "# diameter = 0.001\n# linear_density = 0.001\nstrain,force\n";
    for (int k = 0; k <= 10; ++k) f << 0.1 * k << "," << 5.0 - 0.4 * k << "\n";
  }
  expect_bad_input(dir, {"fit-material", falling, "--out", out}, "falling.points.csv",
                   {"broken.points.csv", "falling.points.csv", "prism.scene.json"});
}

TEST(CliDesign, AnUnbuildableDesignNamesTheCableAndWritesNothing) {
  ScratchDir dir("cli-design-unbuildable");
  const std::string scene = gravity_prism(dir);
  // A cord a thousand times weaker than the 1 mm one: tops out at 6 mN.
  CableMaterial weak = read_material_file(kSource + "/data/materials/elastic-cord-1mm.json");
  for (double& c : weak.coefficients) c *= 1e-3;
  weak.name = "weak-cord";
  const std::string weak_path = dir.file("weak-cord.json");
  write_material_file(weak, weak_path);
  const ProgramRun r = dir.run({"design", scene, "--material", weak_path, "--out", dir.file("out.design.json"),
                                "--sheet", dir.file("out.csv")});
  EXPECT_EQ(r.exit_status, 1) << r.err;
  const std::string last = r.err.substr(r.err.rfind('\n', r.err.size() - 2) + 1);
  EXPECT_NE(last.find(scene), std::string::npos) << last;
  EXPECT_NE(last.find("elements["), std::string::npos) << last;
  EXPECT_NE(last.find("'weak-cord'"), std::string::npos) << last;
  EXPECT_NE(last.find("no design written"), std::string::npos) << last;
  EXPECT_EQ(dir.work_files(), (std::vector<std::string>{"prism.scene.json", "weak-cord.json"}));
}

TEST(CliFitMaterial, RefitsTheShippedCordFromItsPoints) {
  ScratchDir dir("cli-fit-material");
  const std::string out = dir.file("cord.json");
  const ProgramRun r = dir.run({"fit-material", kPoints1mm, "--out", out});
  ASSERT_EQ(r.exit_status, 0) << r.err;
  EXPECT_TRUE(is_one_line(r.err)) << r.err;
  EXPECT_NE(r.err.find("monotone"), std::string::npos) << r.err;
  const CableMaterial fitted = read_material_file(out);
  const CableMaterial shipped = read_material_file(kSource + "/data/materials/elastic-cord-1mm.json");
  EXPECT_EQ(fitted.name, "elastic-cord-1mm");
  EXPECT_DOUBLE_EQ(fitted.strain_min, shipped.strain_min);
  EXPECT_DOUBLE_EQ(fitted.strain_max, shipped.strain_max);
  for (double eps = 0.0; eps <= 1.0; eps += 0.05)
    EXPECT_NEAR(fitted.force(eps), shipped.force(eps), 1e-9) << eps;
}

}  // namespace
}  // namespace tensegrity
