#include "src/core/json.h"

#include <cstdint>
#include <limits>

#include "src/core/error.h"
#include "src/core/file.h"

namespace pano4d {

Json ParseJson(std::string_view text, const std::string& source) {
  try {
    return Json::parse(text.begin(), text.end());
  } catch (const Json::exception& e) {
    // A syntax error is a parse_error, a number that does not fit a double
    // (1e999) an out_of_range. The message starts with a tag such as
    // "[json.exception.parse_error.101] "; keep the part after it.
    std::string message = e.what();
    const std::size_t tag_end = message.find("] ");
    if (tag_end != std::string::npos) message = message.substr(tag_end + 2);
    throw Error::In(source, "not valid JSON (" + message + ")");
  }
}

Json ReadJson(const std::filesystem::path& path) {
  return ParseJson(ReadTextFile(path), path.string());
}

void WriteJson(const std::filesystem::path& path, const Json& value,
               int indent) {
  WriteFileAtomically(path, value.dump(indent) + "\n");
}

std::string JsonValueForMessage(const Json& value, std::size_t max_chars) {
  std::string text = value.dump();
  if (text.size() > max_chars) text = text.substr(0, max_chars) + "...";
  return text;
}

std::optional<JsonDifference> FirstDifference(const Json& first,
                                              const Json& second) {
  if (first == second) return std::nullopt;
  if (!first.is_object() || !second.is_object())
    return JsonDifference{"", first, second};
  // nlohmann's objects iterate in key order.
  Json keys = Json::object();
  for (const auto& item : first.items()) keys[item.key()] = true;
  for (const auto& item : second.items()) keys[item.key()] = true;
  for (const auto& item : keys.items()) {
    const std::string& key = item.key();
    const Json a = first.contains(key) ? first[key] : Json();
    const Json b = second.contains(key) ? second[key] : Json();
    if (first.contains(key) && second.contains(key)) {
      if (std::optional<JsonDifference> d = FirstDifference(a, b)) {
        d->path = d->path.empty() ? key : key + "." + d->path;
        return d;
      }
    } else {
      return JsonDifference{key, a, b};
    }
  }
  return std::nullopt;
}

namespace {

const Json& Field(const Json& object, const std::string& key,
                  const std::string& source) {
  if (!object.is_object()) {
    throw Error(source, key, JsonValueForMessage(object),
                "expected a JSON object containing this field");
  }
  const auto it = object.find(key);
  if (it == object.end()) throw Error(source, key, "", "missing");
  return *it;
}

[[noreturn]] void WrongType(const Json& value, const std::string& key,
                            const std::string& source, const char* expected) {
  throw Error(
      source, key, JsonValueForMessage(value),
      std::string("expected ") + expected + ", got a " + value.type_name());
}

template <typename Int>
Int ToInteger(const Json& value, const std::string& key,
              const std::string& source) {
  if (!value.is_number_integer()) WrongType(value, key, source, "an integer");
  if (value.is_number_unsigned()) {
    const auto u = value.get<std::uint64_t>();
    if (u > static_cast<std::uint64_t>(std::numeric_limits<Int>::max())) {
      throw Error(source, key, value.dump(), "integer out of range");
    }
    return static_cast<Int>(u);
  }
  const auto i = value.get<std::int64_t>();
  if (i < std::numeric_limits<Int>::min() ||
      i > std::numeric_limits<Int>::max()) {
    throw Error(source, key, value.dump(), "integer out of range");
  }
  return static_cast<Int>(i);
}

}  // namespace

template <>
Json GetJson<Json>(const Json& object, const std::string& key,
                   const std::string& source) {
  return Field(object, key, source);
}

template <>
bool GetJson<bool>(const Json& object, const std::string& key,
                   const std::string& source) {
  const Json& value = Field(object, key, source);
  if (!value.is_boolean()) WrongType(value, key, source, "true or false");
  return value.get<bool>();
}

template <>
int GetJson<int>(const Json& object, const std::string& key,
                 const std::string& source) {
  return ToInteger<int>(Field(object, key, source), key, source);
}

template <>
std::int64_t GetJson<std::int64_t>(const Json& object, const std::string& key,
                                   const std::string& source) {
  return ToInteger<std::int64_t>(Field(object, key, source), key, source);
}

template <>
double GetJson<double>(const Json& object, const std::string& key,
                       const std::string& source) {
  const Json& value = Field(object, key, source);
  if (!value.is_number()) WrongType(value, key, source, "a number");
  return value.get<double>();
}

template <>
std::string GetJson<std::string>(const Json& object, const std::string& key,
                                 const std::string& source) {
  const Json& value = Field(object, key, source);
  if (!value.is_string()) WrongType(value, key, source, "a string");
  return value.get<std::string>();
}

template <>
std::vector<double> GetJson<std::vector<double>>(const Json& object,
                                                 const std::string& key,
                                                 const std::string& source) {
  const Json& value = Field(object, key, source);
  if (!value.is_array()) WrongType(value, key, source, "an array of numbers");
  std::vector<double> out;
  out.reserve(value.size());
  for (std::size_t i = 0; i < value.size(); ++i) {
    if (!value[i].is_number()) {
      throw Error(source, key + "[" + std::to_string(i) + "]",
                  JsonValueForMessage(value[i]), "expected a number");
    }
    out.push_back(value[i].get<double>());
  }
  return out;
}

template <>
std::vector<int> GetJson<std::vector<int>>(const Json& object,
                                           const std::string& key,
                                           const std::string& source) {
  const Json& value = Field(object, key, source);
  if (!value.is_array()) WrongType(value, key, source, "an array of integers");
  std::vector<int> out;
  out.reserve(value.size());
  for (std::size_t i = 0; i < value.size(); ++i) {
    out.push_back(
        ToInteger<int>(value[i], key + "[" + std::to_string(i) + "]", source));
  }
  return out;
}

}  // namespace pano4d
