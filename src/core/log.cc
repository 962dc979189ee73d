#include "src/core/log.h"

#include <atomic>
#include <chrono>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <mutex>

#include "src/core/error.h"

namespace pano4d {
namespace {

std::atomic<LogLevel> g_level{LogLevel::kInfo};
std::mutex g_mutex;  // guards everything below and the console itself
std::ostream* g_sink = nullptr;
std::unique_ptr<std::ofstream> g_file;
std::ostream* g_live_line = nullptr;

char LevelLetter(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug:
      return 'D';
    case LogLevel::kInfo:
      return 'I';
    case LogLevel::kWarning:
      return 'W';
    case LogLevel::kError:
      return 'E';
  }
  return '?';
}

std::string Timestamp() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const auto millis = std::chrono::duration_cast<std::chrono::milliseconds>(
                          now.time_since_epoch())
                          .count() %
                      1000;
  std::tm local{};
  localtime_r(&seconds, &local);
  std::ostringstream out;
  out << std::put_time(&local, "%H:%M:%S") << '.' << std::setw(3)
      << std::setfill('0') << millis;
  return out.str();
}

}  // namespace

void SetLogLevel(LogLevel level) { g_level = level; }
LogLevel GetLogLevel() { return g_level; }

std::optional<LogLevel> ParseLogLevel(std::string_view name) {
  if (name == "debug") return LogLevel::kDebug;
  if (name == "info") return LogLevel::kInfo;
  if (name == "warning" || name == "warn") return LogLevel::kWarning;
  if (name == "error") return LogLevel::kError;
  return std::nullopt;
}

void SetLogSink(std::ostream* sink) {
  std::lock_guard<std::mutex> lock(g_mutex);
  g_sink = sink;
}

void SetLogFile(const std::filesystem::path& path) {
  std::lock_guard<std::mutex> lock(g_mutex);
  g_file.reset();
  if (path.empty()) return;
  auto file = std::make_unique<std::ofstream>(path, std::ios::app);
  if (!*file)
    throw Error::In(path.string(), "cannot open the log file for appending");
  g_file = std::move(file);
}

void Log(LogLevel level, std::string_view message) {
  if (level < g_level.load()) return;
  const std::string line = std::string(1, LevelLetter(level)) + " " +
                           Timestamp() + " " + std::string(message) + "\n";
  std::lock_guard<std::mutex> lock(g_mutex);
  std::ostream& sink = g_sink ? *g_sink : std::cerr;
  if (g_live_line == &sink) {
    sink << "\r\033[K";  // erase the progress line; it redraws on its next
                         // update
    g_live_line = nullptr;
  }
  sink << line << std::flush;
  if (g_file) *g_file << line << std::flush;
}

namespace internal {

void WriteConsole(std::ostream& stream, std::string_view text, bool live) {
  std::lock_guard<std::mutex> lock(g_mutex);
  stream << text << std::flush;
  g_live_line = live ? &stream : nullptr;
}

}  // namespace internal
}  // namespace pano4d
