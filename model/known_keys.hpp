#pragma once
// Strict but extensible files. Every object of a file format has a list of
// known keys. A key that is not known but lies within a small edit distance of
// a known one is taken for a typo and is an input error ("fixd" on a node
// would otherwise leave the node free, silently). Any other unknown key is
// allowed, because formats promise that fields may be added: the parser keeps
// it where the format carries extras, and the keys are reported in one
// warning per file through the input-warning sink below (the library itself
// never prints).
#include <cstddef>
#include <functional>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace tensegrity {

// Optimal string alignment distance (Damerau-Levenshtein without repeated
// edits of one substring): the least number of insertions, deletions,
// substitutions and swaps of two adjacent characters that turn `a` into `b`.
std::size_t edit_distance(std::string_view a, std::string_view b);

// Largest edit distance at which `key` counts as a misspelling of `known`:
// 1 when either has 3 characters or fewer ("mas" for "mass"), else 2.
std::size_t typo_distance_limit(std::string_view key, std::string_view known);

// The known key that `key` misspells (the closest; the earliest listed on a
// tie), or "" when `key` is known itself or near none of them.
std::string misspelled_key(std::string_view key, const std::vector<std::string_view>& known);

// Checks the keys of every object of one file and collects its unknown keys.
class KeyChecker {
 public:
  explicit KeyChecker(std::string source) : source_(std::move(source)) {}

  // `object` is the JSON object at path `item` ("" at the top, "nodes[3]"...).
  // Throws InputError(source, item, "unknown key 'fixd' (did you mean
  // 'fixed'?)") for a misspelled key; records every other unknown key as
  // "item.key". Does nothing for a non-object (the parser reports its type).
  void check(const nlohmann::json& object, std::initializer_list<std::string_view> known,
             const std::string& item);
  void check(const nlohmann::json& object, const std::vector<std::string_view>& known, const std::string& item);

  // Paths of the unknown keys found so far, in the order met, each once.
  const std::vector<std::string>& unknown_keys() const { return unknown_; }
  const std::string& source() const { return source_; }

  // Sends "unknown keys kept: nodes[3].color, name2" to the input-warning
  // sink when there is any (a long list is cut after the first ten).
  void report() const;

 private:
  std::string source_;
  std::vector<std::string> unknown_;
  std::set<std::string> seen_;
};

// The message of KeyChecker::report(), or "" when there are no unknown keys.
std::string unknown_keys_message(const std::vector<std::string>& unknown_keys);

// ---- input warnings ----------------------------------------------------------

// Receives a warning about input that was accepted: the file and the message.
using InputWarningSink = std::function<void(const std::string& file, const std::string& message)>;

// Installs `sink` for the whole process while the object lives (the previous
// one comes back afterwards). Without a sink, warnings are dropped.
class ScopedInputWarningSink {
 public:
  explicit ScopedInputWarningSink(InputWarningSink sink);
  ~ScopedInputWarningSink();
  ScopedInputWarningSink(const ScopedInputWarningSink&) = delete;
  ScopedInputWarningSink& operator=(const ScopedInputWarningSink&) = delete;

 private:
  InputWarningSink previous_;
};

// Passes a warning to the installed sink, if any (thread-safe).
void warn_about_input(const std::string& file, const std::string& message);

}  // namespace tensegrity
