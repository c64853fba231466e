// common/json_fields: every error names the file and the JSON path of the field, in the
// wording of the format; a value of the wrong type is never accepted.
#include "common/json_fields.hpp"

#include <gtest/gtest.h>

#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "common/error.hpp"

namespace {

using namespace rayline;
using nlohmann::json;

// Runs `f`, which must throw InputError; returns it.
InputError error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "no InputError";
  return InputError("", "", "");
}

void expect_error(const std::function<void()>& f, const std::string& field, const std::string& what) {
  const InputError e = error_of(f);
  EXPECT_EQ(e.file(), "in.json");
  EXPECT_EQ(e.field(), field);
  EXPECT_EQ(e.what(), what);
}

const JsonInput kInput("in.json");
const json kDoc = json::parse(R"({
  "name": "x", "empty": "", "n": 2.5, "i": -3, "u": 7, "big": 18446744073709551615,
  "list": [1, "two", {"k": true}], "obj": {"a": 1, "b": 2},
  "size": "8GiB", "bw": "150MB/s", "t": "2ms", "rate": "10M/s", "bad_size": "8 GiB"
})");

TEST(JsonFields, Paths) {
  EXPECT_EQ(field_key("", "name"), "name");
  EXPECT_EQ(field_key("nodes[2]", "memory"), "nodes[2].memory");
  EXPECT_EQ(field_index("nodes", 2), "nodes[2]");
  const JsonField root = kInput.field(kDoc, "");
  EXPECT_EQ(root.at("list").element(2).at("k").path(), "list[2].k");
  EXPECT_EQ(root.at("obj").members()[1].field.path(), "obj.b");
  EXPECT_EQ(root.at("obj").members()[1].key, "b");
  ASSERT_EQ(root.at("list").elements().size(), 3u);
  EXPECT_EQ(root.at("list").elements()[1].path(), "list[1]");
  EXPECT_EQ(kInput.field(kDoc, "$").at("name").path(), "$.name");
}

TEST(JsonFields, EachErrorNamesFileAndField) {
  const JsonField root = kInput.field(kDoc, "");
  expect_error([&] { root.at("nope"); }, "nope", "in.json: nope: missing");
  expect_error([&] { root.at("list").element(2).at("k").string(); }, "list[2].k",
               "in.json: list[2].k: expected a string");
  expect_error([&] { root.at("list").element(3); }, "list[3]", "in.json: list[3]: missing");
  expect_error([&] { root.at("obj").only_keys({"a"}); }, "obj.b", "in.json: obj.b: unknown key");
  expect_error([&] { root.at("name").only_keys({"a"}); }, "name", "in.json: name: expected an object");
  expect_error([&] { root.at("empty").non_empty_string(); }, "empty", "in.json: empty: expected a non-empty string");
  const InputError unit = error_of([&] { root.at("bad_size").quantity(JsonUnit::bytes); });
  EXPECT_EQ(unit.field(), "bad_size");
  EXPECT_TRUE(std::string(unit.what()).starts_with("in.json: bad_size: '8 GiB' is not a valid size")) << unit.what();
  expect_error([&] { root.at("i").integer(0, 10); }, "i", "in.json: i: expected an integer from 0 to 10");
  expect_error([&] { root.fail_at("absent", "why"); }, "absent", "in.json: absent: why");
  const InputError parse = error_of([] { kInput.parse("{,}"); });
  EXPECT_EQ(parse.field(), "");
  EXPECT_TRUE(std::string(parse.what()).starts_with("in.json: invalid JSON: [json.exception")) << parse.what();
}

// A helper that let a value of another type through would make every loader accept it.
TEST(JsonFields, WrongTypesAreRejected) {
  const JsonField root = kInput.field(kDoc, "");
  EXPECT_THROW(root.at("n").string(), InputError);
  EXPECT_THROW(root.at("u").non_empty_string(), InputError);
  EXPECT_THROW(root.at("name").number(), InputError);
  EXPECT_THROW(root.at("n").integer(), InputError);
  EXPECT_THROW(root.at("big").integer(), InputError);  // above 2^63 - 1
  EXPECT_THROW(root.at("i").unsigned_integer(), InputError);
  EXPECT_THROW(root.at("n").unsigned_integer(), InputError);
  EXPECT_THROW(root.at("list").object(), InputError);
  EXPECT_THROW(root.at("obj").array(), InputError);
  EXPECT_THROW(root.at("obj").elements(), InputError);
  EXPECT_THROW(root.at("list").members(), InputError);
  EXPECT_THROW(root.at("u").quantity(JsonUnit::bytes), InputError);
  EXPECT_THROW(root.at("bw").quantity(JsonUnit::duration), InputError);
  EXPECT_THROW(root.at("u").integer(8, 10), InputError);
  EXPECT_THROW(root.at("name").integer(0, 10), InputError);
}

TEST(JsonFields, ValuesOfTheRightTypeAreRead) {
  const JsonField root = kInput.field(kDoc, "");
  EXPECT_EQ(root.at("name").string(), "x");
  EXPECT_EQ(root.at("empty").string(), "");
  EXPECT_EQ(root.at("name").non_empty_string(), "x");
  EXPECT_DOUBLE_EQ(root.at("n").number(), 2.5);
  EXPECT_DOUBLE_EQ(root.at("u").number(), 7);
  EXPECT_EQ(root.at("i").integer(), -3);
  EXPECT_EQ(root.at("u").integer(), 7);
  EXPECT_EQ(root.at("u").integer(1, 7), 7);
  EXPECT_EQ(root.at("u").unsigned_integer(), 7u);
  EXPECT_DOUBLE_EQ(root.at("size").quantity(JsonUnit::bytes), 8.0 * (1u << 30));
  EXPECT_DOUBLE_EQ(root.at("bw").quantity(JsonUnit::bandwidth), 150e6);
  EXPECT_DOUBLE_EQ(root.at("t").quantity(JsonUnit::duration), 2e-3);
  EXPECT_DOUBLE_EQ(root.at("rate").quantity(JsonUnit::rate), 10e6);
  EXPECT_TRUE(root.has("obj"));
  EXPECT_FALSE(root.has("nope"));
  EXPECT_FALSE(root.at("list").has("k"));  // not an object: no members
  EXPECT_FALSE(root.find("nope").has_value());
  EXPECT_EQ(root.find("obj")->path(), "obj");
  EXPECT_NO_THROW(root.at("obj").only_keys({"a", "b", "c"}));
}

TEST(JsonFields, WordingOfTheFormat) {
  const JsonInput platform("p.json", {.type_prefix = "expected ",
                                      .name_actual_type = true,
                                      .unknown_key = "unknown key",
                                      .list_allowed_keys = true,
                                      .top_level = "(top level)"});
  const json list = json::array();
  EXPECT_STREQ(error_of([&] { platform.field(list, "").only_keys({"b", "a"}); }).what(),
               "p.json: (top level): expected an object, got array");
  EXPECT_STREQ(error_of([&] { platform.field(kDoc, "").only_keys({"name", "b"}); }).what(),
               "p.json: bad_size: unknown key (allowed: b, name)");
  EXPECT_STREQ(error_of([&] { platform.field(kDoc, "").at("n").non_empty_string(); }).what(),
               "p.json: n: expected a non-empty string, got number");
  // The range message names the range, not the type.
  EXPECT_STREQ(error_of([&] { platform.field(kDoc, "").at("name").integer(1, 4); }).what(),
               "p.json: name: expected an integer from 1 to 4");

  const OrderedJsonInput scene("s.json", {.type_prefix = "must be ",
                                         .name_actual_type = false,
                                         .unknown_key = "unknown field",
                                         .list_allowed_keys = false,
                                         .top_level = ""});
  const nlohmann::ordered_json doc = scene.parse(R"({"z": 1, "a": "x"})");
  const OrderedJsonField root = scene.field(doc, "");
  EXPECT_EQ(root.members()[0].key, "z");  // the file's order
  EXPECT_STREQ(error_of([&] { root.at("a").number(); }).what(), "s.json: a: must be a number");
  EXPECT_STREQ(error_of([&] { root.only_keys({"a"}); }).what(), "s.json: z: unknown field");
}

TEST(JsonFields, ParseOptions) {
  const JsonParseOptions strict{.reject_duplicate_keys = true, .drop_exception_tag = true};
  EXPECT_STREQ(error_of([] { kInput.parse(R"({"a": [{"n": 1, "n": 2}]})", {.reject_duplicate_keys = true}); }).what(),
               "in.json: a[].n: duplicate key");
  EXPECT_NO_THROW(kInput.parse(R"({"a": [{"n": 1}, {"n": 2}]})", strict));
  EXPECT_NO_THROW(kInput.parse(R"({"n": 1, "n": 2})"));  // JSON allows it: the last one wins
  const std::string what = error_of([&] { kInput.parse("[1,", strict); }).what();
  EXPECT_TRUE(what.starts_with("in.json: invalid JSON: parse error at line 1, column 4")) << what;
}

// Hostile documents end in an InputError naming the file, with or without the duplicate-key
// check: nesting 100 000 levels deep (code that walks a document recursively would
// overflow the stack) and a number no double holds (nlohmann throws out_of_range, not
// parse_error).
TEST(JsonFields, DeepNestingAndNumberOverflowAreInputErrors) {
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  const std::string deep_objects = [] {
    std::string t;
    for (int i = 0; i < 100000; ++i) t += "{\"a\":";
    return t + "1" + std::string(100000, '}');
  }();
  for (const JsonParseOptions options : {JsonParseOptions{}, JsonParseOptions{.reject_duplicate_keys = true}}) {
    for (const std::string* text : {&deep, &deep_objects}) {
      const InputError e = error_of([&] { kInput.parse(*text, options); });
      EXPECT_EQ(e.file(), "in.json");
      EXPECT_NE(std::string(e.what()).find("nested more than 256 levels"), std::string::npos) << e.what();
    }
    const InputError e = error_of([&] { kInput.parse(R"({"capacity": 1e400})", options); });
    EXPECT_EQ(e.file(), "in.json");
    EXPECT_NE(std::string(e.what()).find("invalid JSON"), std::string::npos) << e.what();
  }
  // Nesting a real file could have still parses.
  EXPECT_NO_THROW(kInput.parse(std::string(200, '[') + std::string(200, ']')));
}

}  // namespace
