#pragma once

#include <filesystem>
#include <optional>
#include <ostream>
#include <sstream>
#include <string_view>

namespace pano4d {

enum class LogLevel { kDebug = 0, kInfo = 1, kWarning = 2, kError = 3 };

// Messages below the level are dropped. Default kInfo.
void SetLogLevel(LogLevel level);
LogLevel GetLogLevel();
// "debug", "info", "warning", "error"; nullopt otherwise.
std::optional<LogLevel> ParseLogLevel(std::string_view name);

// Where messages go: std::cerr by default; tests may point it at a string
// stream (nullptr restores std::cerr). The sink must outlive its use.
void SetLogSink(std::ostream* sink);
// Also appends every message to `path` (e.g. WS/pano4d/logs/pano4d.log);
// an empty path stops that. Throws pano4d::Error if it cannot be opened.
void SetLogFile(const std::filesystem::path& path);

// One line: "I 12:34:56.789 message". Thread-safe; a live progress bar on the
// same terminal is cleared first and redraws itself on its next update.
void Log(LogLevel level, std::string_view message);

// Collects a streamed message and logs it when destroyed; use PANO4D_LOG.
class LogMessage {
 public:
  explicit LogMessage(LogLevel level) : level_(level) {}
  ~LogMessage() { Log(level_, stream_.str()); }
  std::ostream& stream() { return stream_; }

 private:
  LogLevel level_;
  std::ostringstream stream_;
};

namespace internal {
// Writes `text` to `stream` under the lock that Log uses, so progress lines
// and log lines never interleave. `live` marks an unfinished line (a
// progress bar redrawn in place), which the next Log on that stream erases.
void WriteConsole(std::ostream& stream, std::string_view text, bool live);
}  // namespace internal

}  // namespace pano4d

// PANO4D_LOG(kInfo) << "registered " << n << " frames";
// The message is not even formatted when the level is below GetLogLevel().
#define PANO4D_LOG(severity)                                    \
  if (::pano4d::LogLevel::severity < ::pano4d::GetLogLevel()) { \
  } else                                                        \
    ::pano4d::LogMessage(::pano4d::LogLevel::severity).stream()
