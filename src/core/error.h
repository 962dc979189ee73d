#pragma once

#include <stdexcept>
#include <string>

namespace pano4d {

// The one error type of pano4d. It says which input was wrong (a file, or
// another named source such as a command-line flag), which field inside it,
// the value found there, and what is wrong with it. what() joins these into a
// single line, for example:
//   cam.json: field 'width' = "640": expected an integer
// Empty parts are left out.
class Error : public std::runtime_error {
 public:
  Error(std::string source, std::string field, std::string value,
        std::string problem);

  // An error about a whole input, with no particular field.
  static Error In(std::string source, std::string problem);

  const std::string& source() const { return source_; }
  const std::string& field() const { return field_; }
  const std::string& value() const { return value_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string source_;
  std::string field_;
  std::string value_;
  std::string problem_;
};

}  // namespace pano4d
