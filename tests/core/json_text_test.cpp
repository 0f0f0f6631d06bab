#include "imukit/core/json_text.hpp"

#include <gtest/gtest.h>

#include <string>

#include "support/expect_error.hpp"

namespace imukit {
namespace {

std::string message_of(std::string_view text, int depth = 64) {
  try {
    (void)parse_json_text<nlohmann::json>(text, "f.json", depth);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(JsonText, SyntaxErrorsNameLineAndColumnInCharacters) {
  // The stray 'x' is on line 3; "é" before it is two bytes but one column.
  EXPECT_EQ(message_of("{\n  \"a\": 1,\n  \"é\": x}").rfind("f.json:3:8: ", 0), 0u)
      << message_of("{\n  \"a\": 1,\n  \"é\": x}");
  // At the end of the input: where the missing bracket belongs.
  EXPECT_EQ(message_of("[1, 2").rfind("f.json:1:6: ", 0), 0u) << message_of("[1, 2");
  // No nlohmann prefix in the reason.
  EXPECT_EQ(message_of("{").find("json.exception"), std::string::npos);
  // A number too large for a double is located too (the DOM parser loses that position).
  EXPECT_EQ(message_of("{\"v\": 1e999}").rfind("f.json:1:", 0), 0u);
}

TEST(JsonText, NestingBeyondTheLimitIsRejectedAtItsBracket) {
  const std::string deep = std::string(5, '[') + std::string(5, ']');
  EXPECT_EQ(parse_json_text<nlohmann::ordered_json>(deep, "f.json", 5).dump(), "[[[[[]]]]]");
  EXPECT_EQ(message_of(deep, 4), "f.json:1:5: nesting deeper than 4 levels");
  // Brackets inside strings do not count.
  EXPECT_EQ(parse_json_text<nlohmann::json>("[\"[[[[[[\"]", "f.json", 1)[0], "[[[[[[");
}

TEST(JsonText, AKeyGivenTwiceInOneObjectIsAnErrorAtItsSecondOccurrence) {
  // The second "sigma" is on line 3, column 3; the same key in another object, or as a value, is
  // fine and must not be mistaken for it.
  const std::string text =
      "{\"a\": {\"sigma\": 1}, \"b\": \"sigma\",\n \"sigma\": 2,\n  \"sigma\": 3}";
  EXPECT_EQ(message_of(text),
            "f.json:3:3: duplicate key 'sigma': each key may appear once in an object");
  EXPECT_EQ(
      parse_json_text<nlohmann::json>("{\"a\": {\"k\": 1}, \"b\": {\"k\": 2}}", "f.json").dump(),
      "{\"a\":{\"k\":1},\"b\":{\"k\":2}}");
  // Escapes in keys: "\u0061" is "a", so it duplicates "a"; the error points at the escaped one.
  EXPECT_EQ(message_of("[{\"a\\\"\": 0, \"a\": 1, \"\\u0061\": 2}]").rfind("f.json:1:21: ", 0), 0u)
      << message_of("[{\"a\\\"\": 0, \"a\": 1, \"\\u0061\": 2}]");
  EXPECT_NE(message_of("{\"k\": 1, \"k\": 2}").find("duplicate key"), std::string::npos);
  EXPECT_THROW((void)parse_json_text<nlohmann::ordered_json>("{\"k\": 1, \"k\": 2}", "f.json"),
               Error);
}

TEST(JsonText, PathOffsetFindsTheValueOrItsDeepestAncestor) {
  // Strings holding brackets, commas and escaped quotes do not confuse the scan.
  const std::string_view text =
      R"({"a": "x,]}\"", "b": [{"c": 1}, {"c": [10, "]", {"d": null}]}], "e": {}})";
  const auto at = [&](std::string_view path) {
    return std::string(text.substr(json_path_offset(text, path), 6));
  };
  EXPECT_EQ(json_path_offset(text, ""), 0u);
  EXPECT_EQ(at("a"), R"("x,]}\)");
  EXPECT_EQ(at("b[1].c[2].d"), "null}]");
  EXPECT_EQ(at("b[1].c[1]"), R"("]", {)");
  EXPECT_EQ(at("b[0].c"), "1}, {\"");
  EXPECT_EQ(at("e.missing"), "{}}");  // the object lacking the key
  EXPECT_EQ(at("b[5]"), at("b"));     // past the array's end: the array
  EXPECT_EQ(at("(top level)"), at(""));
}

TEST(JsonFields, TypedReadsReturnTheValueOrNameTheFileThePathAndTheProblem) {
  using testing::expect_error;
  const nlohmann::json j = nlohmann::json::parse(
      R"({"rate": 200.5, "name": "wrist", "on": true, "g": [0, 0, -9.81], "big": 1e308})");
  EXPECT_EQ(json_number(j["rate"], "s.json", "rate"), 200.5);
  EXPECT_EQ(json_string(j["name"], "s.json", "name"), "wrist");
  EXPECT_TRUE(json_boolean(j["on"], "s.json", "on"));
  EXPECT_EQ(json_vec3(j["g"], "s.json", "g"), Eigen::Vector3d(0, 0, -9.81));
  json_only_keys(j, {"rate", "name", "on", "g", "big"}, "s.json", "");

  expect_error([&] { json_number(j["name"], "s.json", "a.rate"); },
               {"s.json: a.rate: expected a number, got string"});
  expect_error([&] { json_number(nlohmann::json(1e308 * 10), "s.json", "x"); },
               {"s.json: x: expected a finite number"});
  expect_error([&] { json_string(j["rate"], "s.json", "name"); },
               {"s.json: name: expected a string, got number"});
  expect_error([&] { json_boolean(j["name"], "s.json", "on"); },
               {"s.json: on: expected true or false, got string"});
  expect_error([&] { json_vec3(j["name"], "s.json", "g"); },
               {"s.json: g: expected an array of 3 numbers"});
  expect_error([&] { json_vec3(nlohmann::json::parse(R"([0, "1", 2])"), "s.json", "g"); },
               {"s.json: g[1]: expected a number, got string"});
  // A misspelt key is named with the keys it could have been.
  expect_error(
      [&] {
        json_only_keys(j, {"rate", "name", "on", "g"}, "s.json", "sensor");
      },
      {"s.json: sensor: unknown key 'big' (known: rate, name, on, g)"});
  expect_error([&] { json_only_keys(j["g"], {"x"}, "s.json", "g"); },
               {"s.json: g: expected an object, got array"});
}

}  // namespace
}  // namespace imukit
