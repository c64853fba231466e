// Typed access to the fields of a JSON input file (platform, job set, scene profile,
// scene): every problem becomes InputError(file, JSON path of the field, message), which
// the CLI prints as "FILE: FIELD: message" (docs/architecture.md, "Bad input").
//
// A JsonField is a value of the document together with its path ("nodes[2].memory[0]"):
// at("capacity") and element(i) extend the path, so a loader never spells one out, and the
// checks (only_keys, string, integer, quantity, ...) throw at the path of the value they
// check. Each format keeps the wording its users know ("expected a string" in platform
// files, "must be a string" in scenes): JsonWording says how a loader words its messages.
// Only the forward declarations of nlohmann/json reach this header; the loaders that walk
// a document include <nlohmann/json.hpp> in their .cpp files.
#pragma once
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rayline {

// Objects and arrays nested deeper than this are refused while parsing (here and by the
// glTF reader): no format Rayline reads nests more than a few levels, and code that walks
// a document recursively (a merge, a dump in a message) would overflow the stack on a
// file nested 100 000 levels deep.
inline constexpr int kMaxJsonDepth = 256;

// Field paths in messages: a key below a path ("nodes[2]" + "name" = "nodes[2].name"; at
// the top level just "name") and an element of an array ("nodes" + 2 = "nodes[2]").
std::string field_key(std::string_view path, std::string_view key);
std::string field_index(std::string_view path, std::size_t index);

// How a format words its messages. A type check says type_prefix + what it expected:
// "expected a string", "must be a string"; with name_actual_type it adds ", got number".
struct JsonWording {
  std::string_view type_prefix = "expected ";
  bool name_actual_type = false;
  std::string_view unknown_key = "unknown key";
  bool list_allowed_keys = false;  // "unknown key (allowed: a, b, c)", in sorted order
  std::string_view top_level;      // the field an error about the whole document names
};

struct JsonParseOptions {
  // JSON lets a key repeat (the last one wins); a file where that is almost always a
  // copy-paste slip rejects it, naming the key's path ("nodes[].name": arrays unnumbered).
  bool reject_duplicate_keys = false;
  // "invalid JSON: parse error at line 1, column 2: ..." without nlohmann's
  // "[json.exception.parse_error.101] " tag.
  bool drop_exception_tag = false;
};

// The quantities of common/units.hpp a field may hold as a string ("8GiB", "150MB/s").
enum class JsonUnit { bytes, bandwidth, duration, rate };

template <class Json>
class BasicJsonField;

// One input file: its name (the FILE of every message) and its wording.
template <class Json>
class BasicJsonInput {
 public:
  explicit BasicJsonInput(std::string file, JsonWording wording = {});

  const std::string& file() const { return file_; }
  const JsonWording& wording() const { return wording_; }

  // The document; invalid JSON is InputError(file, "", "invalid JSON: ...").
  Json parse(std::string_view text, JsonParseOptions options = {}) const;
  // `value` (which must outlive the field) reported at `path`; the document is at "".
  BasicJsonField<Json> field(const Json& value, std::string path) const;

  [[noreturn]] void fail(const std::string& field, const std::string& message) const;
  // A quantity with a unit; units.hpp's message (what was expected) at `field`.
  double quantity(std::string_view text, const std::string& field, JsonUnit unit) const;

 private:
  std::string file_;
  JsonWording wording_;
};

template <class Json>
class BasicJsonField {
 public:
  struct Member;

  BasicJsonField(const BasicJsonInput<Json>& input, const Json& value, std::string path)
      : input_(&input), value_(&value), path_(std::move(path)) {}

  const BasicJsonInput<Json>& input() const { return *input_; }
  const Json& json() const { return *value_; }
  const std::string& path() const { return path_; }
  [[noreturn]] void fail(const std::string& message) const;
  // Fails at the path of member `key`, present or not ("version: expected 1").
  [[noreturn]] void fail_at(std::string_view key, const std::string& message) const;

  // Members. at() is a required key ("missing" at its path); find() an optional one.
  bool has(std::string_view key) const;
  BasicJsonField at(std::string_view key) const;
  std::optional<BasicJsonField> find(std::string_view key) const;
  // An object with no key outside `allowed`: a typo must not fall back to a default.
  void only_keys(std::initializer_list<std::string_view> allowed) const;
  std::vector<Member> members() const;  // an object's members, in the document's order

  // Elements of an array (element() and elements() check the type: array()); an index
  // past the end is "missing" at its path. size() counts an object's members too.
  std::size_t size() const;
  BasicJsonField element(std::size_t index) const;
  std::vector<BasicJsonField> elements() const;

  // Type checks: each returns the value or throws type_prefix + what it expected.
  const BasicJsonField& object() const;
  const BasicJsonField& array() const;
  std::string string() const;
  std::string non_empty_string() const;
  double number() const;
  bool boolean() const;
  std::int64_t integer() const;
  std::uint64_t unsigned_integer() const;  // "a non-negative integer"
  // "an integer from LO to HI": the range is the message, whatever the value's type.
  std::int64_t integer(std::int64_t lo, std::int64_t hi) const;
  // A non-empty string holding a quantity of `unit` (units.hpp's message when malformed).
  double quantity(JsonUnit unit) const;

 private:
  [[noreturn]] void wrong_type(std::string_view expected) const;

  const BasicJsonInput<Json>* input_;
  const Json* value_;
  std::string path_;
};

template <class Json>
struct BasicJsonField<Json>::Member {
  std::string key;
  BasicJsonField field;
};

using JsonInput = BasicJsonInput<nlohmann::json>;
using JsonField = BasicJsonField<nlohmann::json>;
// Scenes keep their file's key order (the first camera is the default).
using OrderedJsonInput = BasicJsonInput<nlohmann::ordered_json>;
using OrderedJsonField = BasicJsonField<nlohmann::ordered_json>;

}  // namespace rayline
