#pragma once

#include <cstddef>
#include <cstdio>
#include <string>
#include <string_view>

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

// An image size as messages and tables write it: "480x270" (width first).
inline std::string SizeText(long long width, long long height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

// Orders names as people number files: runs of digits compare by value
// ("frame_2" < "frame_10"), the rest byte by byte; equal values with
// different zero padding ("7" and "007") fall back to byte order. The
// order of frames given as files, for their time.
inline bool NaturalLess(std::string_view a, std::string_view b) {
  const auto digit = [](char c) { return c >= '0' && c <= '9'; };
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (digit(a[i]) && digit(b[j])) {
      std::size_t ei = i, ej = j;
      while (ei < a.size() && digit(a[ei])) ++ei;
      while (ej < b.size() && digit(b[ej])) ++ej;
      // Compare values without overflow: strip leading zeros, then by
      // length, then digit by digit.
      std::size_t si = i, sj = j;
      while (si + 1 < ei && a[si] == '0') ++si;
      while (sj + 1 < ej && b[sj] == '0') ++sj;
      if (ei - si != ej - sj) return ei - si < ej - sj;
      const int c = a.substr(si, ei - si).compare(b.substr(sj, ej - sj));
      if (c != 0) return c < 0;
      i = ei;
      j = ej;
    } else {
      if (a[i] != b[j])
        return static_cast<unsigned char>(a[i]) <
               static_cast<unsigned char>(b[j]);
      ++i;
      ++j;
    }
  }
  if ((i < a.size()) != (j < b.size())) return j < b.size();
  return a < b;
}

}  // namespace pano4d
