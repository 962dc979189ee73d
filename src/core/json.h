#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace pano4d {

using Json = nlohmann::json;

// Parses `text`; a syntax error becomes an Error naming `source` and the byte
// offset. ReadJson reads and parses a file (source = its path).
Json ParseJson(std::string_view text, const std::string& source);
Json ReadJson(const std::filesystem::path& path);

// Writes `value` (pretty-printed, trailing newline) atomically.
void WriteJson(const std::filesystem::path& path, const Json& value,
               int indent = 2);

// Strictly typed field access. `object` must be a JSON object holding `key`
// with a value of type T; otherwise throws an Error naming `source`, the key,
// the value found and the type expected. Supported T: bool, int, int64_t,
// double, std::string, std::vector<double>, std::vector<int>, Json.
// Integers accept only JSON integers (640, not 640.0 or "640"); doubles accept
// any JSON number but not NaN-like strings.
template <typename T>
T GetJson(const Json& object, const std::string& key,
          const std::string& source);
template <>
Json GetJson<Json>(const Json&, const std::string&, const std::string&);
template <>
bool GetJson<bool>(const Json&, const std::string&, const std::string&);
template <>
int GetJson<int>(const Json&, const std::string&, const std::string&);
template <>
std::int64_t GetJson<std::int64_t>(const Json&, const std::string&,
                                   const std::string&);
template <>
double GetJson<double>(const Json&, const std::string&, const std::string&);
template <>
std::string GetJson<std::string>(const Json&, const std::string&,
                                 const std::string&);
template <>
std::vector<double> GetJson<std::vector<double>>(const Json&,
                                                 const std::string&,
                                                 const std::string&);
template <>
std::vector<int> GetJson<std::vector<int>>(const Json&, const std::string&,
                                           const std::string&);

// As GetJson, but returns `fallback` when the key is absent (a present key of
// the wrong type is still an error).
template <typename T>
T GetJsonOr(const Json& object, const std::string& key, const T& fallback,
            const std::string& source) {
  if (!object.is_object() || !object.contains(key)) return fallback;
  return GetJson<T>(object, key, source);
}

// The value rendered for an error message, shortened to `max_chars`.
std::string JsonValueForMessage(const Json& value, std::size_t max_chars = 60);

// Where two JSON values first differ, as a key path into objects ("init.
// num_bases"; the empty path when the values themselves differ in type or
// as arrays or scalars), with both values; nothing when they are equal.
// Keys are visited in order, and a key only one side has is a difference.
struct JsonDifference {
  std::string path;
  Json first, second;  // absent on a side: null
};
std::optional<JsonDifference> FirstDifference(const Json& first,
                                              const Json& second);

}  // namespace pano4d
