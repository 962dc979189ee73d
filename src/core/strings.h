#pragma once

#include <cstdio>
#include <string>

namespace pano4d {

// printf into a std::string of whatever length it needs: the reports and
// summaries the stages print.
template <typename... Args>
std::string StringPrintf(const char* format, Args... args) {
  const int n = std::snprintf(nullptr, 0, format, args...);
  if (n <= 0) return std::string();
  std::string s(static_cast<std::size_t>(n), '\0');
  std::snprintf(s.data(), s.size() + 1, format, args...);
  return s;
}

}  // namespace pano4d
