#include "src/core/memory.h"

#include <fstream>
#include <sstream>

#include "src/core/error.h"
#include "src/core/strings.h"

namespace pano4d {

std::optional<std::uint64_t> AvailableMemoryBytes() {
  std::ifstream meminfo("/proc/meminfo");
  std::string line;
  while (std::getline(meminfo, line)) {
    if (line.rfind("MemAvailable:", 0) != 0) continue;
    std::istringstream fields(line.substr(13));
    std::uint64_t kib = 0;
    if (fields >> kib) return kib * 1024;
  }
  return std::nullopt;
}

void CheckMemoryFits(double bytes, const std::string& source,
                     const std::string& what) {
  const std::optional<std::uint64_t> available = AvailableMemoryBytes();
  if (!available || bytes <= static_cast<double>(*available)) return;
  constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;
  throw Error::In(source,
                  StringPrintf("needs %.1f GiB for %s; %.1f GiB is available",
                               bytes / kGiB, what.c_str(), *available / kGiB));
}

}  // namespace pano4d
