#include "src/core/error.h"

#include <utility>

namespace pano4d {
namespace {

std::string FormatError(const std::string& source, const std::string& field,
                        const std::string& value, const std::string& problem) {
  std::string line = source.empty() ? std::string("pano4d") : source;
  if (!field.empty()) line += ": field '" + field + "'";
  if (!value.empty()) line += (field.empty() ? ": " : " = ") + value;
  line += ": " + problem;
  // One error, one line: a multi-line message would split across log readers.
  for (char& c : line) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return line;
}

}  // namespace

Error::Error(std::string source, std::string field, std::string value,
             std::string problem)
    : std::runtime_error(FormatError(source, field, value, problem)),
      source_(std::move(source)),
      field_(std::move(field)),
      value_(std::move(value)),
      problem_(std::move(problem)) {}

Error Error::In(std::string source, std::string problem) {
  return Error(std::move(source), "", "", std::move(problem));
}

}  // namespace pano4d
