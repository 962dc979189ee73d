#pragma once

// Internal invariants, kept apart from bad input. `Error` is for what a
// user gave (a file, a flag) and tells them what to change; a failed
// PANO4D_CHECK is a bug in pano4d itself (sizes that drifted apart, a
// caller passing another forward's state) and says so, with the file and
// line, so that nobody hunts for a mistake in their input. The CLI exits
// with kExitBug (70, sysexits' EX_SOFTWARE) for it.
//
//   PANO4D_CHECK(state.width == camera.width,
//                "the rasterizer's backward got another forward's state");

#include <stdexcept>
#include <string>

namespace pano4d {

class InternalError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

namespace internal {
[[noreturn]] void CheckFailed(const char* condition, const char* file, int line,
                              const std::string& message);
}  // namespace internal

}  // namespace pano4d

#define PANO4D_CHECK(condition, message)                              \
  do {                                                                \
    if (!(condition))                                                 \
      ::pano4d::internal::CheckFailed(#condition, __FILE__, __LINE__, \
                                      (message));                     \
  } while (0)
