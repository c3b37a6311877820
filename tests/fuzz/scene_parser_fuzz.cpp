// libFuzzer target: arbitrary bytes through the scene parser, as `tensegrity`
// reads a file (parse_json_text, then scene_from_json with validation). Bad
// input must end in InputError; a scene that is accepted must survive a write
// and re-read unchanged. Anything else (a crash, another exception, a
// sanitizer report) is a finding.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/scene_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace tensegrity;
  const std::string text(reinterpret_cast<const char*>(data), size);
  Structure scene;
  try {
    scene = scene_from_json(parse_json_text(text, "fuzz.scene.json"), "fuzz.scene.json");
  } catch (const InputError&) {
    return 0;
  }
  // Accepted: the model's own output must read back to the same structure.
  const Structure again = scene_from_json(scene_to_json(scene), "round-trip");
  if (again.num_nodes() != scene.num_nodes() || again.num_elements() != scene.num_elements() ||
      again.positions != scene.positions || again.fixed != scene.fixed || again.node_mass != scene.node_mass ||
      again.gravity != scene.gravity)
    std::abort();
  return 0;
}
