// JSON text to a document, with errors an editor can jump to. A syntax error names
// file:line:column (columns in characters, not bytes) and what was wrong, in nlohmann's words
// without its prefix; nesting deeper than a limit is rejected before parsing, because readers
// that recurse over the document would otherwise spend stack on hostile input; a key given twice
// in one object is an error at the second one. Every imukit
// reader of JSON files (profiles, scenes, policies) parses through here.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "imukit/core/error.hpp"

namespace imukit {

// 1-based line and column of the byte at `offset` (clamped to the text).
InputLocation locate_in_text(std::string_view text, std::size_t offset, const std::string& source);

// Throws imukit::Error at the first bracket nested deeper than max_depth (outside strings).
void check_json_depth(std::string_view text, const std::string& source, int max_depth);

// nlohmann's exception text without "[json.exception...] parse error at line L, column C: ".
std::string json_error_reason(std::string message);

// Byte offset of the opening quote of the n-th (1-based) object key in well-formed JSON text, in
// document order; text.size() when there are fewer keys.
std::size_t json_key_offset(std::string_view text, std::size_t n);

// Byte offset of the value at `path` in well-formed JSON text: object keys joined by '.', array
// elements as [i] ("accelerometer.noise.allan.adev[1][3]"), "" for the root. Where the path
// leaves the document (a missing key), the offset of the deepest value it reaches, so an error
// about a key that is absent points at the object that lacks it.
std::size_t json_path_offset(std::string_view text, std::string_view path);

namespace detail {

// Builds the document from nlohmann's SAX events, recording where a parse error happened (its
// DOM parser drops the position of some errors, e.g. number overflow). Only the innermost open
// container grows, so pointers to its ancestors stay valid.
template <class Json>
class JsonDomBuilder {
 public:
  explicit JsonDomBuilder(Json& root) : root_(root) {}

  bool null() { return put(nullptr); }
  bool boolean(bool v) { return put(v); }
  bool number_integer(typename Json::number_integer_t v) { return put(v); }
  bool number_unsigned(typename Json::number_unsigned_t v) { return put(v); }
  bool number_float(typename Json::number_float_t v, const typename Json::string_t&) {
    return put(v);
  }
  bool string(typename Json::string_t& v) { return put(std::move(v)); }
  bool binary(typename Json::binary_t& v) { return put(Json::binary(std::move(v))); }
  bool start_object(std::size_t) {
    put(Json::object());
    stack_.push_back(last_);
    return true;
  }
  // A key given twice in one object is an error, not "the last one wins": a profile or scene
  // edited by hand would otherwise lose the first value without a word.
  bool key(typename Json::string_t& k) {
    ++keys_read;
    if (stack_.back()->contains(k)) {
      duplicate_key = std::move(k);
      return false;
    }
    key_ = std::move(k);
    return true;
  }
  bool end_object() {
    stack_.pop_back();
    return true;
  }
  bool start_array(std::size_t) {
    put(Json::array());
    stack_.push_back(last_);
    return true;
  }
  bool end_array() {
    stack_.pop_back();
    return true;
  }
  bool parse_error(std::size_t position, const std::string&, const nlohmann::detail::exception& e) {
    error_position = position;
    error_message = json_error_reason(e.what());
    return false;
  }

  std::size_t error_position = 0;
  std::string error_message;
  std::size_t keys_read = 0;
  std::optional<typename Json::string_t> duplicate_key;

 private:
  bool put(Json&& value) {
    if (stack_.empty()) {
      root_ = std::move(value);
      last_ = &root_;
    } else if (stack_.back()->is_array()) {
      stack_.back()->push_back(std::move(value));
      last_ = &stack_.back()->back();
    } else {
      Json& slot = (*stack_.back())[key_];
      slot = std::move(value);
      last_ = &slot;
    }
    return true;
  }

  Json& root_;
  Json* last_ = nullptr;
  std::vector<Json*> stack_;
  typename Json::string_t key_;
};

}  // namespace detail

// Typed reads of one value of a parsed document, for the readers whose errors name the file and
// the value's JSON path ("scene.json: sensors[0].position_m[2]: expected a number, got string")
// rather than a line and column (profiles do that: core/profile.cpp keeps the text). Each throws
// imukit::Error.
[[noreturn]] void json_fail(const std::string& source, const std::string& path,
                            const std::string& what);
double json_number(const nlohmann::json& j, const std::string& source,
                   const std::string& path);  // finite
std::string json_string(const nlohmann::json& j, const std::string& source,
                        const std::string& path);
bool json_boolean(const nlohmann::json& j, const std::string& source, const std::string& path);
Eigen::Vector3d json_vec3(const nlohmann::json& j, const std::string& source,
                          const std::string& path);  // three finite numbers
// j must be an object whose keys are all in `keys`: a misspelt optional key is an error naming
// the keys it could have been, not a setting silently left at its default.
void json_only_keys(const nlohmann::json& j, std::initializer_list<std::string_view> keys,
                    const std::string& source, const std::string& path);

// Json: nlohmann::json or nlohmann::ordered_json. Throws imukit::Error naming source:line:column.
template <class Json>
Json parse_json_text(std::string_view text, const std::string& source, int max_depth = 64) {
  check_json_depth(text, source, max_depth);
  Json root;
  detail::JsonDomBuilder<Json> builder(root);
  if (!Json::sax_parse(text.begin(), text.end(), &builder)) {
    if (builder.duplicate_key) {
      throw Error(locate_in_text(text, json_key_offset(text, builder.keys_read), source),
                  "duplicate key " + quote_excerpt(*builder.duplicate_key) +
                      ": each key may appear once in an object");
    }
    // The position counts characters read, so the offending byte is the one before it.
    const std::size_t offset = builder.error_position > 0 ? builder.error_position - 1 : 0;
    throw Error(locate_in_text(text, offset, source), builder.error_message);
  }
  return root;
}

}  // namespace imukit
