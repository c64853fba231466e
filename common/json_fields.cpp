// Typed access to JSON input fields (see json_fields.hpp).
#include "common/json_fields.hpp"

#include <algorithm>
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>

#include "common/error.hpp"
#include "common/units.hpp"

namespace rayline {

std::string field_key(std::string_view path, std::string_view key) {
  std::string out(path);
  if (!out.empty()) out += '.';
  return out.append(key);
}

std::string field_index(std::string_view path, std::size_t index) {
  return std::string(path) + "[" + std::to_string(index) + "]";
}

namespace {

template <class Json>
void check_depth(const BasicJsonInput<Json>& input, int depth, typename Json::parse_event_t event) {
  using E = typename Json::parse_event_t;
  if ((event == E::object_start || event == E::array_start) && depth >= kMaxJsonDepth)
    input.fail("", "invalid JSON: objects and arrays nested more than " + std::to_string(kMaxJsonDepth) + " levels deep");
}

// Parser callback that rejects a key repeated inside one object. Its path names array
// elements "[]": the parser does not count them.
template <class Json>
class DuplicateKeys {
 public:
  explicit DuplicateKeys(const BasicJsonInput<Json>& input) : input_(input) {}

  bool operator()(int depth, typename Json::parse_event_t event, Json& value) {
    using E = typename Json::parse_event_t;
    check_depth(input_, depth, event);
    if (event == E::object_start || event == E::array_start) {
      open(event == E::object_start);
    } else if (event == E::object_end || event == E::array_end) {
      if (!stack_.empty()) stack_.pop_back();
    } else if (event == E::key && !stack_.empty()) {
      const std::string key = value.is_string() ? value.template get<std::string>() : std::string();
      if (!stack_.back().keys.insert(key).second) input_.fail(field_key(path(), key), "duplicate key");
      stack_.back().key = key;
    }
    return true;
  }

 private:
  struct Frame {
    bool object;
    std::string name, key;
    std::set<std::string> keys;
  };

  void open(bool object) {
    std::string name;
    if (!stack_.empty()) name = stack_.back().object ? stack_.back().key : "[]";
    stack_.push_back({object, name, "", {}});
  }
  std::string path() const {
    std::string p;
    for (std::size_t i = 1; i < stack_.size(); ++i)
      p += stack_[i].name == "[]" ? "[]" : (p.empty() ? "" : ".") + stack_[i].name;
    return p;
  }

  const BasicJsonInput<Json>& input_;
  std::vector<Frame> stack_;
};

// An integer JSON number that std::int64_t holds (unsigned ones above 2^63 - 1 do not).
template <class Json>
bool is_int64(const Json& v) {
  return v.is_number_integer() &&
         !(v.is_number_unsigned() && v.template get<std::uint64_t>() > std::uint64_t(INT64_MAX));
}

// nlohmann's message is "[json.exception.parse_error.101] parse error at line L, ...".
std::string without_exception_tag(std::string message) {
  if (const auto p = message.find("] "); message.starts_with("[json.exception") && p != std::string::npos)
    message.erase(0, p + 2);
  return message;
}

}  // namespace

// ---------------------------------------------------------------- BasicJsonInput

template <class Json>
BasicJsonInput<Json>::BasicJsonInput(std::string file, JsonWording wording)
    : file_(std::move(file)), wording_(wording) {}

template <class Json>
Json BasicJsonInput<Json>::parse(std::string_view text, JsonParseOptions options) const {
  try {
    if (!options.reject_duplicate_keys)
      return Json::parse(text, [this](int depth, typename Json::parse_event_t event, Json&) {
        check_depth(*this, depth, event);
        return true;
      });
    DuplicateKeys<Json> duplicates(*this);
    return Json::parse(text, std::ref(duplicates));
  } catch (const nlohmann::json::exception& e) {
    // parse_error, and out_of_range for a number no double holds ("1e400").
    fail("", "invalid JSON: " + (options.drop_exception_tag ? without_exception_tag(e.what()) : std::string(e.what())));
  }
}

template <class Json>
BasicJsonField<Json> BasicJsonInput<Json>::field(const Json& value, std::string path) const {
  return BasicJsonField<Json>(*this, value, std::move(path));
}

template <class Json>
void BasicJsonInput<Json>::fail(const std::string& field, const std::string& message) const {
  throw InputError(file_, field, message);
}

template <class Json>
double BasicJsonInput<Json>::quantity(std::string_view text, const std::string& field, JsonUnit unit) const {
  try {
    switch (unit) {
      case JsonUnit::bytes: return units::parse_bytes(text);
      case JsonUnit::bandwidth: return units::parse_bandwidth(text);
      case JsonUnit::duration: return units::parse_duration(text);
      case JsonUnit::rate: return units::parse_rate(text);
    }
  } catch (const std::invalid_argument& e) {
    fail(field, e.what());
  }
  fail(field, "unknown unit kind");
}

// ---------------------------------------------------------------- BasicJsonField

template <class Json>
void BasicJsonField<Json>::fail(const std::string& message) const {
  input_->fail(path_, message);
}

template <class Json>
void BasicJsonField<Json>::fail_at(std::string_view key, const std::string& message) const {
  input_->fail(field_key(path_, key), message);
}

template <class Json>
void BasicJsonField<Json>::wrong_type(std::string_view expected) const {
  const JsonWording& w = input_->wording();
  std::string message = std::string(w.type_prefix).append(expected);
  if (w.name_actual_type) message += std::string(", got ") + value_->type_name();
  fail(message);
}

template <class Json>
bool BasicJsonField<Json>::has(std::string_view key) const {
  return value_->is_object() && value_->find(key) != value_->end();
}

template <class Json>
BasicJsonField<Json> BasicJsonField<Json>::at(std::string_view key) const {
  if (auto f = find(key)) return *f;
  input_->fail(field_key(path_, key), "missing");
}

template <class Json>
std::optional<BasicJsonField<Json>> BasicJsonField<Json>::find(std::string_view key) const {
  if (!value_->is_object()) return std::nullopt;
  const auto it = value_->find(key);
  if (it == value_->end()) return std::nullopt;
  return BasicJsonField(*input_, *it, field_key(path_, key));
}

template <class Json>
void BasicJsonField<Json>::only_keys(std::initializer_list<std::string_view> allowed) const {
  const JsonWording& w = input_->wording();
  if (!value_->is_object()) {
    BasicJsonField at_top(*input_, *value_, path_.empty() ? std::string(w.top_level) : path_);
    at_top.wrong_type("an object");
  }
  for (auto it = value_->begin(); it != value_->end(); ++it) {
    if (std::find(allowed.begin(), allowed.end(), it.key()) != allowed.end()) continue;
    std::string message(w.unknown_key);
    if (w.list_allowed_keys) {
      std::vector<std::string_view> sorted(allowed);
      std::sort(sorted.begin(), sorted.end());
      std::string list;
      for (std::string_view a : sorted) list.append(list.empty() ? "" : ", ").append(a);
      message += " (allowed: " + list + ")";
    }
    input_->fail(field_key(path_, it.key()), message);
  }
}

template <class Json>
std::vector<typename BasicJsonField<Json>::Member> BasicJsonField<Json>::members() const {
  object();
  std::vector<Member> out;
  for (auto it = value_->begin(); it != value_->end(); ++it)
    out.push_back({it.key(), BasicJsonField(*input_, it.value(), field_key(path_, it.key()))});
  return out;
}

template <class Json>
std::size_t BasicJsonField<Json>::size() const {
  return value_->size();
}

template <class Json>
BasicJsonField<Json> BasicJsonField<Json>::element(std::size_t index) const {
  array();
  if (index >= value_->size()) input_->fail(field_index(path_, index), "missing");
  return BasicJsonField(*input_, (*value_)[index], field_index(path_, index));
}

template <class Json>
std::vector<BasicJsonField<Json>> BasicJsonField<Json>::elements() const {
  array();
  std::vector<BasicJsonField> out;
  out.reserve(value_->size());
  for (std::size_t i = 0; i < value_->size(); ++i) out.emplace_back(*input_, (*value_)[i], field_index(path_, i));
  return out;
}

template <class Json>
const BasicJsonField<Json>& BasicJsonField<Json>::object() const {
  if (!value_->is_object()) wrong_type("an object");
  return *this;
}

template <class Json>
const BasicJsonField<Json>& BasicJsonField<Json>::array() const {
  if (!value_->is_array()) wrong_type("an array");
  return *this;
}

template <class Json>
std::string BasicJsonField<Json>::string() const {
  if (!value_->is_string()) wrong_type("a string");
  return value_->template get<std::string>();
}

template <class Json>
std::string BasicJsonField<Json>::non_empty_string() const {
  if (!value_->is_string() || value_->template get_ref<const std::string&>().empty()) wrong_type("a non-empty string");
  return value_->template get<std::string>();
}

template <class Json>
double BasicJsonField<Json>::number() const {
  if (!value_->is_number()) wrong_type("a number");
  return value_->template get<double>();
}

template <class Json>
std::int64_t BasicJsonField<Json>::integer() const {
  if (!is_int64(*value_)) wrong_type("an integer");
  return value_->template get<std::int64_t>();
}

template <class Json>
bool BasicJsonField<Json>::boolean() const {
  if (!value_->is_boolean()) wrong_type("true or false");
  return value_->template get<bool>();
}

template <class Json>
std::uint64_t BasicJsonField<Json>::unsigned_integer() const {
  if (!value_->is_number_unsigned()) wrong_type("a non-negative integer");
  return value_->template get<std::uint64_t>();
}

template <class Json>
std::int64_t BasicJsonField<Json>::integer(std::int64_t lo, std::int64_t hi) const {
  const bool in_range = is_int64(*value_) && value_->template get<std::int64_t>() >= lo &&
                        value_->template get<std::int64_t>() <= hi;
  if (!in_range)
    fail(std::string(input_->wording().type_prefix) + "an integer from " + std::to_string(lo) + " to " +
         std::to_string(hi));
  return value_->template get<std::int64_t>();
}

template <class Json>
double BasicJsonField<Json>::quantity(JsonUnit unit) const {
  return input_->quantity(non_empty_string(), path_, unit);
}

template class BasicJsonInput<nlohmann::json>;
template class BasicJsonInput<nlohmann::ordered_json>;
template class BasicJsonField<nlohmann::json>;
template class BasicJsonField<nlohmann::ordered_json>;

}  // namespace rayline
