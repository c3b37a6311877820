// tensegrity serve [SCENE|CHARACTER|DESIGN] [--port 8080] [--open] [--write] [--time-limit S]
//
// The interactive design loop of the paper (section 3) in a browser: a local
// web app on 127.0.0.1 only, its files (web/, three.js from web/node_modules)
// served by this process, and a JSON API under /api/ (docs/WEB.md) that calls
// the same library as the other commands: no solver logic runs in the page.
// One file past 500 lines: every route shares the WebApp's state (input,
// simulation sessions, their locks), which stays private to it.
//
// Bad requests get 400 and the one line the CLI would print for the same
// input ("tensegrity: request: ITEM: REASON"); the server keeps serving.
#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <vector>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "cli/commands.hpp"
#include "reports/design_pipeline.hpp"
#include "reports/fabrication_sheet.hpp"
#include "cli/link_suggestion_report.hpp"
#include "reports/output.hpp"
#include "formulations/elastic_energy.hpp"
#include "model/character.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/scene_io.hpp"
#include "simulation/link_suggestion.hpp"
#include "simulation/simulator.hpp"

// Last: it includes <resolv.h>, whose macros would break Eigen's headers.
#include <httplib.h>

#ifndef TENSEGRITY_WEB_DIR
#define TENSEGRITY_WEB_DIR "web"
#endif

extern char** environ;

namespace tensegrity::cli {

namespace {

// Names the request body in error messages, as a file name does on the command line.
constexpr const char* kRequestSource = "request";
constexpr std::size_t kMaxRequestBytes = 64u << 20;
constexpr int kMaxSimulations = 8;     // older ones are dropped first
constexpr int kMaxStepsPerRequest = 100;
constexpr double kDefaultServeTimeLimit = 60.0;  // s, per solve or design
// A browser keeps up to six idle keep-alive connections per host and each
// holds a worker thread while it waits, so the pool must be larger than that
// plus the long solves running at once.
constexpr std::size_t kWorkerThreads = 32;
constexpr std::size_t kKeepAliveRequests = 100000;  // the simulation loop reuses one connection
// cpp-httplib brotli-compresses exactly "application/json" and
// "application/javascript" for browsers, at a cost far above the transfer
// time on the loopback; these spellings are not compressed.
constexpr const char* kJsonType = "application/json; charset=utf-8";
constexpr const char* kScriptType = "application/javascript; charset=utf-8";

struct ServeArgs {
  std::string input;
  std::string web_root = TENSEGRITY_WEB_DIR;
  int port = 8080;
  bool open = false;
  bool write_back = false;  // --write: edits of a character go back to its file
  double time_limit = kDefaultServeTimeLimit;
};

// One interactive simulation (POST /api/simulation, then its steps).
struct Session {
  std::mutex mutex;
  ElasticModel model;
  std::unique_ptr<Simulator> simulator;
  double drag_stiffness = 0.0;  // N/m
  int steps = 0;
};

class WebApp {
 public:
  explicit WebApp(const ServeArgs& args) : args_(args) {}

  // The file named on the command line: kind and JSON for the page. Bad input
  // fails here, before the server starts (exit status 2).
  void load_input() {
    library_ = BlockLibrary::standard();
    if (args_.input.empty()) {
      initial_ = {{"kind", "none"}};
      return;
    }
    const nlohmann::json j = read_json_file(args_.input);
    const std::string format =
        j.is_object() && j.contains("format") && j.at("format").is_string() ? j.at("format").get<std::string>() : "";
    if (format == "tensegrity-character") {
      build_character_file(args_.input);  // validates the file and its block library
      namespace fs = std::filesystem;
      const std::string rel = j.contains("block_library") && j.at("block_library").is_string()
                                  ? j.at("block_library").get<std::string>()
                                  : "../blocks";
      library_ = BlockLibrary::load((fs::path(args_.input).parent_path() / rel).lexically_normal().string());
      initial_ = {{"kind", "character"}, {"json", j}};
    } else if (format == "tensegrity-design") {
      design_from_json(j, args_.input);
      initial_ = {{"kind", "design"}, {"json", j}};
    } else {
      scene_from_json(j, args_.input);
      initial_ = {{"kind", "scene"}, {"json", j}};
    }
    initial_["file"] = std::filesystem::path(args_.input).filename().string();
  }

  // Only pages of this server may use it: a request naming another host (a
  // DNS-rebinding page) or sent from another origin (a cross-site form post)
  // is refused before any handler runs.
  void accept_only_local_origin(httplib::Server& server, int port) {
    const std::string suffix = ":" + std::to_string(port);
    const std::vector<std::string> hosts = {"127.0.0.1" + suffix, "localhost" + suffix};
    server.set_pre_routing_handler([hosts](const httplib::Request& req, httplib::Response& res) {
      const auto local = [&hosts](const std::string& host) {
        return std::find(hosts.begin(), hosts.end(), host) != hosts.end();
      };
      const std::string origin = req.get_header_value("Origin");
      const std::string origin_host = origin.rfind("http://", 0) == 0 ? origin.substr(7) : origin;
      if (!local(req.get_header_value("Host"))) {
        reply_error(res, 403, std::string(kRequestSource) + ": Host: not this server (127.0.0.1 or localhost, port " +
                                  hosts.front().substr(hosts.front().find(':') + 1) + ")");
      } else if (!origin.empty() && !local(origin_host)) {
        reply_error(res, 403, std::string(kRequestSource) + ": Origin: '" + origin + "' is not this server");
      } else {
        return httplib::Server::HandlerResponse::Unhandled;
      }
      return httplib::Server::HandlerResponse::Handled;
    });
  }

  void install(httplib::Server& server) {
    server.set_payload_max_length(kMaxRequestBytes);
    server.set_read_timeout(5, 0);
    server.set_keep_alive_max_count(kKeepAliveRequests);
    server.set_keep_alive_timeout(2);
    server.set_tcp_nodelay(true);  // small answers, one after another: no Nagle delay
    server.new_task_queue = [] { return new httplib::ThreadPool(kWorkerThreads); };
    for (const auto& [ext, type] : std::map<std::string, std::string>{{"js", kScriptType},
                                                                      {"mjs", kScriptType},
                                                                      {"css", "text/css"},
                                                                      {"html", "text/html"},
                                                                      {"json", kJsonType},
                                                                      {"png", "image/png"},
                                                                      {"svg", "image/svg+xml"}})
      server.set_file_extension_and_mimetype_mapping(ext, type);
    namespace fs = std::filesystem;
    const fs::path root(args_.web_root);
    if (!server.set_mount_point("/", (root / "app").string()))
      throw InputError(args_.web_root, "app", "folder of the web app not found");
    const fs::path three = root / "node_modules" / "three";
    if (!server.set_mount_point("/vendor/three", three.string()))
      std::cerr << "tensegrity: " << three.string() << ": missing: run `npm ci` in web/ (scripts/setup.sh)\n";

    server.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
      try {
        std::rethrow_exception(ep);
      } catch (const UnknownNameError& e) {
        // A solver name of the request is named as the request's option.
        reply_error(res, 400, InputError(kRequestSource, e.item(), e.reason()).what());
      } catch (const InputError& e) {
        // Options shared with the CLI (solver names, tolerances) come from the request here.
        reply_error(res, 400, e.file() == "command line" ? InputError(kRequestSource, e.item(), e.reason()).what()
                                                         : e.what());
      } catch (const std::bad_alloc&) {
        reply_error(res, 500, "out of memory");
      } catch (const std::exception& e) {
        reply_error(res, 500, std::string("error: ") + e.what());
      } catch (...) {
        reply_error(res, 500, "error: unknown exception");
      }
    });

    server.Get("/api/info", [this](const httplib::Request&, httplib::Response& res) { reply_json(res, info()); });
    server.Post("/api/build", [this](const httplib::Request& req, httplib::Response& res) {
      const BuiltCharacter built = build_character(body_json(req), kRequestSource, library_);
      const auto& c = built.counts;
      reply_json(res, {{"scene", scene_to_json(built.structure)},
                       {"counts", {{"blocks", c.blocks}, {"face_links", c.face_links}, {"edge_links", c.edge_links},
                                   {"nodes", c.nodes}, {"struts", c.struts}, {"cables", c.cables},
                                   {"fixed_nodes", c.fixed_nodes}, {"mass", c.mass}}}});
    });
    server.Put("/api/character", [this](const httplib::Request& req, httplib::Response& res) {
      save_character(req, res);
    });
    server.Post("/api/solve", [this](const httplib::Request& req, httplib::Response& res) { solve(req, res); });
    server.Post("/api/design", [this](const httplib::Request& req, httplib::Response& res) { design(req, res); });
    server.Post("/api/suggest-link", [this](const httplib::Request& req, httplib::Response& res) {
      suggest_link(req, res);
    });
    server.Post("/api/simulation", [this](const httplib::Request& req, httplib::Response& res) {
      start_simulation(req, res);
    });
    server.Post(R"(/api/simulation/(\d+)/step)", [this](const httplib::Request& req, httplib::Response& res) {
      step_simulation(req, res);
    });
    server.Delete(R"(/api/simulation/(\d+))", [this](const httplib::Request& req, httplib::Response& res) {
      std::lock_guard lock(sessions_mutex_);
      sessions_.erase(session_id(req));
      reply_json(res, {{"deleted", true}});
    });
  }

 private:
  static void reply_error(httplib::Response& res, int status, const std::string& message) {
    res.status = status;
    res.set_content("tensegrity: " + message + "\n", "text/plain");
  }
  static void reply_json(httplib::Response& res, const nlohmann::json& j) {
    res.status = 200;
    res.set_content(j.dump(), kJsonType);
  }
  static nlohmann::json body_json(const httplib::Request& req) { return parse_json_text(req.body, kRequestSource); }
  // The simulation id of the path (digits only, by the route's pattern); 0 (no such id) when too long.
  static int session_id(const httplib::Request& req) {
    const std::string digits = req.matches[1].str();
    return digits.size() > 9 ? 0 : std::stoi(digits);
  }

  // Query parameter `key` as a finite number, or `fallback`.
  static double number_param(const httplib::Request& req, const nlohmann::json& body, const char* key,
                             double fallback) {
    if (body.is_object() && body.contains(key)) return json_finite_number(body.at(key), kRequestSource, key);
    if (!req.has_param(key)) return fallback;
    const std::string text = req.get_param_value(key);
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || *end != '\0' || !std::isfinite(v))
      throw InputError(kRequestSource, key, "'" + text + "' is not a finite number");
    return v;
  }
  static std::string string_param(const httplib::Request& req, const nlohmann::json& body, const char* key) {
    if (body.is_object() && body.contains(key)) return json_string(body.at(key), kRequestSource, key);
    return req.has_param(key) ? req.get_param_value(key) : std::string();
  }

  SolveOptions solve_options(const httplib::Request& req, const nlohmann::json& body) const {
    SolveOptions options;
    options.tolerance = number_param(req, body, "tol", options.tolerance);
    const double limit = number_param(req, body, "time_limit", args_.time_limit);
    if (!(limit > 0)) throw InputError(kRequestSource, "time_limit", "must be > 0");
    options.time_limit_s = std::min(limit, args_.time_limit);
    return options;
  }

  nlohmann::json info() const {
    nlohmann::json blocks = nlohmann::json::object();
    for (const std::string& name : library_.names()) {
      const Block& b = library_.get(name, "library", name);
      nlohmann::json faces = nlohmann::json::array(), cables = nlohmann::json::array();
      nlohmann::json face_nodes = nlohmann::json::object(), cable_nodes = nlohmann::json::object();
      for (const auto& [face, nodes] : b.faces) {
        faces.push_back(face);
        face_nodes[face] = nodes;
      }
      for (const auto& [cable, element] : b.cables) {
        cables.push_back(cable);
        cable_nodes[cable] = {b.structure.elements[element].a, b.structure.elements[element].b};
      }
      blocks[name] = {{"faces", faces}, {"cables", cables}, {"face_nodes", face_nodes}, {"cable_nodes", cable_nodes},
                      {"nodes", b.structure.num_nodes()}, {"elements", b.structure.num_elements()}};
    }
    return {{"solvers", solver_names()}, {"default_solver", default_solver_name()}, {"blocks", blocks},
            {"materials", {"elastic-cord-2mm", "elastic-cord-1mm"}}, {"default_material", reports::kDefaultMaterial},
            {"time_limit", args_.time_limit}, {"initial", initial_},
            {"writes_character", writes_character()}};
  }

  bool writes_character() const { return args_.write_back && initial_.value("kind", "") == "character"; }

  // With --write: the edited character replaces the served file once it builds.
  void save_character(const httplib::Request& req, httplib::Response& res) const {
    if (!writes_character()) {
      reply_error(res, 403, std::string(kRequestSource) + ": character: the server was not started with --write CHARACTER");
      return;
    }
    const nlohmann::json j = body_json(req);
    build_character(j, kRequestSource, library_);
    std::lock_guard lock(write_mutex_);
    write_text_file_atomically(args_.input, j.dump(2) + "\n");
    reply_json(res, {{"written", args_.input}});
  }

  // Body: a scene JSON (query ?solver=&tol=&time_limit=), or
  // {"scene": ..., "solver": ..., "tol": ..., "time_limit": ...}. Answer: the solution JSON.
  void solve(const httplib::Request& req, httplib::Response& res) const {
    const nlohmann::json body = body_json(req);
    const bool wrapped = body.is_object() && body.contains("scene") && !body.contains("format");
    const nlohmann::json& params = wrapped ? body : nlohmann::json::object();
    const SolveOptions options = solve_options(req, params);
    const auto solver = reports::checked_solver(string_param(req, params, "solver"), options);
    const Structure scene = scene_from_json(wrapped ? body.at("scene") : body, kRequestSource);
    const std::string name(solver->name());
    const SolveResult r = solve_scene(*solver, scene, options);
    std::cerr << "serve: " << reports::summary_line(scene, name, r) << "\n";
    reply_json(res, solution_to_json(to_solution(r, scene, name)));
  }

  // Body {"input": scene|character|design JSON, "material", "strain", "solver", "tol"}.
  // Answer {"design": design JSON, "sheet": fabrication sheet CSV}; 422 with
  // the CLI's last line when the input has no buildable design.
  void design(const httplib::Request& req, httplib::Response& res) const {
    const nlohmann::json body = body_json(req);
    if (!body.is_object() || !body.contains("input"))
      throw InputError(kRequestSource, "input", "missing (a scene, character or design)");
    const nlohmann::json& input = body.at("input");
    const std::string format = input.is_object() && input.contains("format") && input.at("format").is_string()
                                   ? input.at("format").get<std::string>()
                                   : "";
    Structure scene;
    if (format == "tensegrity-character") scene = build_character(input, kRequestSource, library_).structure;
    else if (format == "tensegrity-design") scene = design_from_json(input, kRequestSource).structure;
    else scene = scene_from_json(input, kRequestSource);
    reports::DesignRequest dr;
    dr.options_source = kRequestSource;
    if (body.contains("material")) dr.material = json_string(body.at("material"), kRequestSource, "material");
    if (dr.material.find('/') != std::string::npos || dr.material.ends_with(".json"))
      throw InputError(kRequestSource, "material", "expected a material name, not a file");
    dr.strain = number_param(req, body, "strain", dr.strain);
    const SolveOptions options = solve_options(req, body);
    dr.tol = options.tolerance;
    dr.time_limit = options.time_limit_s;
    if (!args_.input.empty())  // materials beside the served file's data folder
      dr.material_dirs.push_back(
          (std::filesystem::path(args_.input).parent_path() / ".." / "materials").lexically_normal().string());
    reports::check_design_request(dr);
    const auto solver = reports::checked_solver(string_param(req, body, "solver"), options);
    reports::DesignOutcome out = reports::design_structure(scene, kRequestSource, dr, *solver);
    if (!out.ok) {
      reply_error(res, 422,
                  std::string(kRequestSource) + ": " + (out.failure_item.empty() ? "" : out.failure_item + ": ") +
                      out.failure_reason + "; no design written");
      return;
    }
    reply_json(res, {{"design", design_to_json(out.design)},
                     {"sheet", reports::fabrication_sheet_csv(out.design, out.rest.lengths)},
                     {"strain_range", {out.strain_range.first, out.strain_range.second}}});
  }

  // A whole number option of the request, or `fallback`.
  static int integer_param(const httplib::Request& req, const nlohmann::json& body, const char* key, int fallback) {
    const double v = number_param(req, body, key, fallback);
    if (v != std::floor(v) || std::abs(v) > 1e6) throw InputError(kRequestSource, key, "must be an integer");
    return static_cast<int>(v);
  }

  // Body {"character": character JSON, "a": id, "b": id, "axis": [x, y, z] | "stiff": true,
  // "range", "faces", "cables", "cable_ea", "solver"} (suggest-link's options, its defaults).
  // Answer: the ranking as suggest-link --json writes it; blocks from the served library.
  void suggest_link(const httplib::Request& req, httplib::Response& res) const {
    const nlohmann::json body = body_json(req);
    if (!body.is_object() || !body.contains("character"))
      throw InputError(kRequestSource, "character", "missing (a character)");
    const nlohmann::json& character = body.at("character");
    json_expect_header(character, "tensegrity-character", kRequestSource);
    SuggestLinkSettings settings;
    if (body.contains("axis")) {
      const Eigen::Vector3d axis = json_vector3(body.at("axis"), kRequestSource, "axis");
      settings.axis = {axis.x(), axis.y(), axis.z()};
    }
    if (body.contains("stiff")) {
      if (!body.at("stiff").is_boolean()) throw InputError(kRequestSource, "stiff", "expected true or false");
      settings.stiff = body.at("stiff").get<bool>();
    }
    settings.range_deg = number_param(req, body, "range", settings.range_deg);
    settings.faces = integer_param(req, body, "faces", settings.faces);
    settings.cables = integer_param(req, body, "cables", settings.cables);
    settings.cable_ea = number_param(req, body, "cable_ea", settings.cable_ea);
    settings.solver = string_param(req, body, "solver");
    const CheckedLinkSettings checked = check_link_settings(settings);
    const std::string a = string_param(req, body, "a"), b = string_param(req, body, "b");
    if (a.empty()) throw InputError(kRequestSource, "a", "missing (the id of the first block)");
    if (b.empty()) throw InputError(kRequestSource, "b", "missing (the id of the second block)");
    const auto ranked = suggest_links(character, kRequestSource, library_, a, b, checked.request, checked.options);
    const bool named = character.contains("name") && character.at("name").is_string();
    reply_json(res, link_suggestions_json(ranked, named ? character.at("name").get<std::string>() : kRequestSource, a, b));
  }

  static nlohmann::json state_json(const Session& s) {
    const Simulator& sim = *s.simulator;
    const Eigen::Matrix3Xd& x = sim.positions();
    nlohmann::json positions = nlohmann::json::array();
    for (int i = 0; i < x.cols(); ++i) positions.push_back({x(0, i), x(1, i), x(2, i)});
    const Eigen::VectorXd f = sim.element_forces();
    const Eigen::VectorXd moved = (x - s.model.reference).colwise().norm();
    return {{"time", sim.time()},
            {"steps", s.steps},
            {"positions", std::move(positions)},
            {"forces", std::vector<double>(f.data(), f.data() + f.size())},
            {"max_displacement", moved.size() ? moved.maxCoeff() : 0.0},
            {"kinetic_energy", sim.kinetic_energy()}};
  }

  // Body {"design": design JSON, "dt": s, "damping": 1/s, "stiffness_damping": s}.
  void start_simulation(const httplib::Request& req, httplib::Response& res) {
    const nlohmann::json body = body_json(req);
    if (!body.is_object() || !body.contains("design"))
      throw InputError(kRequestSource, "design", "missing (a design from /api/design)");
    const Design d = design_from_json(body.at("design"), kRequestSource);
    auto session = std::make_shared<Session>();
    session->model = make_elastic_model(d);
    if (!(session->model.structure.lumped_mass().sum() > 0.0))
      throw InputError(kRequestSource, "design", "the design has no mass to simulate");
    SimulationOptions so;
    so.time_step = number_param(req, body, "dt", so.time_step);
    so.mass_damping = number_param(req, body, "damping", so.mass_damping);
    so.stiffness_damping = number_param(req, body, "stiffness_damping", so.stiffness_damping);
    if (!(so.time_step > 0 && so.time_step <= 1.0)) throw InputError(kRequestSource, "dt", "must be in (0, 1] s");
    if (so.mass_damping < 0) throw InputError(kRequestSource, "damping", "must be >= 0");
    if (so.stiffness_damping < 0) throw InputError(kRequestSource, "stiffness_damping", "must be >= 0");
    session->drag_stiffness = session->model.force_scale / (0.05 * session->model.length_scale);
    session->simulator = std::make_unique<Simulator>(session->model, session->model.structure.gravity, so);
    int id;
    {
      std::lock_guard lock(sessions_mutex_);
      id = ++last_session_;
      sessions_[id] = session;
      while (static_cast<int>(sessions_.size()) > kMaxSimulations) sessions_.erase(sessions_.begin());
    }
    nlohmann::json j = state_json(*session);
    j["id"] = id;
    j["drag_stiffness"] = session->drag_stiffness;
    j["dt"] = so.time_step;
    reply_json(res, j);
  }

  // Body {"steps": N, "drags": [{"node": i, "target": [x, y, z]}]}: N implicit-Euler
  // steps with a spring pulling each dragged node to its target (paper, Sec. 3).
  void step_simulation(const httplib::Request& req, httplib::Response& res) {
    std::shared_ptr<Session> session;
    {
      std::lock_guard lock(sessions_mutex_);
      const auto it = sessions_.find(session_id(req));
      if (it == sessions_.end()) {
        reply_error(res, 404, std::string(kRequestSource) + ": simulation: no such simulation (it ended)");
        return;
      }
      session = it->second;
    }
    const nlohmann::json body = req.body.empty() ? nlohmann::json::object() : body_json(req);
    const double steps = number_param(req, body, "steps", 1);
    if (steps != std::floor(steps) || steps < 0 || steps > kMaxStepsPerRequest)
      throw InputError(kRequestSource, "steps", "must be an integer in 0.." + std::to_string(kMaxStepsPerRequest));
    std::lock_guard lock(session->mutex);
    const int n = session->model.structure.num_nodes();
    std::vector<DragSpring> drags;
    if (body.is_object() && body.contains("drags")) {
      const nlohmann::json& list = body.at("drags");
      if (!list.is_array()) throw InputError(kRequestSource, "drags", "expected an array");
      for (std::size_t k = 0; k < list.size(); ++k) {
        const std::string item = "drags[" + std::to_string(k) + "]";
        if (!list[k].is_object() || !list[k].contains("node") || !list[k].contains("target"))
          throw InputError(kRequestSource, item, "expected {\"node\": i, \"target\": [x, y, z]}");
        const double node = json_finite_number(list[k].at("node"), kRequestSource, item + ".node");
        if (node != std::floor(node) || node < 0 || node >= n)
          throw InputError(kRequestSource, item + ".node", "out of range [0, " + std::to_string(n) + ")");
        drags.push_back({static_cast<int>(node), json_vector3(list[k].at("target"), kRequestSource, item + ".target"),
                         session->drag_stiffness});
      }
    }
    Simulator& sim = *session->simulator;
    sim.set_drags(std::move(drags));
    int newton = 0, failed = 0;
    double seconds = 0.0;
    for (int k = 0; k < static_cast<int>(steps); ++k) {
      const StepReport r = sim.step();
      newton += r.newton_iterations;
      seconds += r.seconds;
      failed += r.converged ? 0 : 1;
      ++session->steps;
    }
    nlohmann::json j = state_json(*session);
    j["newton_iterations"] = newton;
    j["step_seconds"] = seconds;
    j["not_converged"] = failed;
    reply_json(res, j);
  }

  ServeArgs args_;
  BlockLibrary library_;
  nlohmann::json initial_;
  mutable std::mutex write_mutex_;
  std::mutex sessions_mutex_;
  std::map<int, std::shared_ptr<Session>> sessions_;
  int last_session_ = 0;
};

httplib::Server* g_server = nullptr;

void stop_server(int) {
  if (g_server) g_server->stop();
}

void open_browser(const std::string& url) {
  pid_t pid;
  const char* argv[] = {"xdg-open", url.c_str(), nullptr};
  if (posix_spawnp(&pid, "xdg-open", nullptr, nullptr, const_cast<char* const*>(argv), environ) != 0)
    std::cerr << "tensegrity: --open: cannot start xdg-open; open " << url << " yourself\n";
}

int run_serve(const ServeArgs& a) {
  if (a.port < 0 || a.port > 65535) throw InputError("command line", "--port", "must be in 0..65535");
  if (!(a.time_limit > 0 && std::isfinite(a.time_limit)))
    throw InputError("command line", "--time-limit", "must be a finite number > 0");
  WebApp app(a);
  app.load_input();
  httplib::Server server;
  // SO_REUSEADDR only: cpp-httplib's default SO_REUSEPORT would let a second
  // server listen on a port already in use and split the connections.
  server.set_socket_options([](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  app.install(server);
  const int port = a.port == 0 ? server.bind_to_any_port("127.0.0.1") : a.port;
  if (port < 0 || (a.port != 0 && !server.bind_to_port("127.0.0.1", a.port)))
    throw InputError("command line", "--port", "cannot listen on 127.0.0.1:" + std::to_string(a.port));
  app.accept_only_local_origin(server, port);
  const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/";
  std::cout << "serving " << url << std::endl;
  if (a.open) open_browser(url);
  g_server = &server;
  std::signal(SIGINT, stop_server);
  std::signal(SIGTERM, stop_server);
  const bool ok = server.listen_after_bind();
  g_server = nullptr;
  return ok ? 0 : 1;
}

}  // namespace

void register_serve_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<ServeArgs>();
  auto* cmd = app.add_subcommand("serve", "Serve the interactive design app on 127.0.0.1 (docs/WEB.md)");
  cmd->add_option("input", args->input, "Scene, character or design to open");
  cmd->add_option("--port", args->port, "TCP port on 127.0.0.1 (default 8080; 0: any free port)");
  cmd->add_flag("--open", args->open, "Open the app in the desktop's browser");
  cmd->add_flag("--write", args->write_back, "Write the character back to its file after every edit that builds");
  cmd->add_option("--time-limit", args->time_limit, "Wall-clock budget of one solve or design in s (default 60)");
  cmd->add_option("--web-root", args->web_root, "Folder holding app/ and node_modules/ (default: the source tree's web/)");
  cmd->callback([args, &run] { run = [args] { return run_serve(*args); }; });
}

}  // namespace tensegrity::cli
