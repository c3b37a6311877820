// libFuzzer target: arbitrary bytes through the character parser with the
// standard block library (parse_json_text, then build_character). Bad input
// must end in InputError; an accepted character must be a valid structure.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "model/blocks.hpp"
#include "model/character.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"

namespace {
const tensegrity::BlockLibrary* library = nullptr;
}  // namespace

// The block library is built once before fuzzing starts, so its construction
// (self-stress searches for the braced blocks) is not charged to any input's timeout.
extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  static const tensegrity::BlockLibrary standard = tensegrity::BlockLibrary::standard();
  library = &standard;
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace tensegrity;
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const BuiltCharacter c = build_character(parse_json_text(text, "fuzz.character.json"), "fuzz.character.json", *library);
    validate(c.structure, "built character");  // must not throw for an accepted character
    if (!c.structure.positions.allFinite()) std::abort();
  } catch (const InputError&) {
    return 0;
  }
  return 0;
}
