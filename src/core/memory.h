#pragma once

// Limits that follow from the machine: work whose memory exceeds what is
// free is refused up front with the figure, rather than found out by the
// kernel's out-of-memory killer minutes later.

#include <cstdint>
#include <optional>
#include <string>

namespace pano4d {

// MemAvailable from /proc/meminfo, in bytes; nullopt where it cannot be
// read (then nothing is refused).
std::optional<std::uint64_t> AvailableMemoryBytes();

// Throws pano4d::Error naming `source` and `what` when `bytes` exceed the
// memory available: "needs 12.3 GiB for 2147483647 frames of 640x480; 3.1
// GiB is available".
void CheckMemoryFits(double bytes, const std::string& source,
                     const std::string& what);

}  // namespace pano4d
