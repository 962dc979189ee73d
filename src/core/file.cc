#include "src/core/file.h"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <regex>
#include <system_error>

#include "src/core/error.h"
#include "src/core/log.h"

namespace pano4d {
namespace fs = std::filesystem;

namespace {

void CheckReadableFile(const fs::path& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) {
    throw Error::In(path.string(), "does not exist");
  }
  if (fs::is_directory(status)) {
    throw Error::In(path.string(), "is a directory, expected a file");
  }
}

}  // namespace

std::vector<std::uint8_t> ReadFileBytes(const fs::path& path) {
  CheckReadableFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw Error::In(path.string(),
                    std::string("cannot be opened: ") + std::strerror(errno));
  }
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
  if (in.bad()) throw Error::In(path.string(), "read failed");
  return bytes;
}

std::string ReadTextFile(const fs::path& path) {
  const std::vector<std::uint8_t> bytes = ReadFileBytes(path);
  return std::string(bytes.begin(), bytes.end());
}

int RemoveLeftoverTemporaries(const fs::path& dir) {
  static const std::regex kTemporary(
      R"(.*\.tmp\.([0-9]{1,10})\.[0-9]+(\.[^.]*)?)");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return 0;
  std::vector<fs::path> leftovers;
  for (auto it = fs::recursive_directory_iterator(
           dir, fs::directory_options::skip_permission_denied, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    std::smatch m;
    const std::string name = it->path().filename().string();
    if (!std::regex_match(name, m, kTemporary)) continue;
    const long long pid = std::stoll(m[1].str());
    // kill(pid, 0) fails with ESRCH when no such process runs.
    if (pid > 0 && pid <= std::numeric_limits<pid_t>::max() &&
        ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH)
      leftovers.push_back(it->path());
  }
  int removed = 0;
  for (const fs::path& p : leftovers) removed += fs::remove(p, ec) ? 1 : 0;
  if (removed > 0) {
    PANO4D_LOG(kInfo) << "removed " << removed
                      << " temporary file(s) that a killed run left under "
                      << dir.string();
  }
  return removed;
}

OutputFolder::OutputFolder(fs::path dir, const std::string& command,
                           const std::string& stale)
    : dir_(std::move(dir)) {
  EnsureDirectory(dir_);
  RemoveLeftoverTemporaries(dir_);
  WriteFileAtomically(
      dir_ / kMarker,
      "Written by `" + command + "` (PID " + std::to_string(::getpid()) +
          "), which has not completed: the files here may mix its output "
          "with an earlier run's. Run it again; it removes this file when it "
          "completes.\n");
  if (stale.empty()) return;
  const std::regex pattern(stale);
  std::error_code ec;
  std::vector<fs::path> old;
  for (auto it = fs::recursive_directory_iterator(dir_, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    const std::string relative =
        it->path().lexically_relative(dir_).generic_string();
    if (it->is_regular_file(ec) && std::regex_match(relative, pattern))
      old.push_back(it->path());
  }
  for (const fs::path& p : old) fs::remove(p, ec);
}

void OutputFolder::Complete() {
  std::error_code ec;
  fs::remove(dir_ / kMarker, ec);
  if (ec) throw Error::In((dir_ / kMarker).string(), ec.message());
}

fs::path TemporaryPathFor(const fs::path& path) {
  static std::atomic<unsigned> counter{0};
  const std::string infix = ".tmp." + std::to_string(::getpid()) + "." +
                            std::to_string(counter.fetch_add(1));
  fs::path tmp = path;
  tmp.replace_filename(path.stem().string() + infix +
                       path.extension().string());
  return tmp;
}

namespace {

// The room left on the file system holding `path` or its nearest existing
// parent (a file about to be written may not exist yet), if it can be told.
std::optional<std::uintmax_t> AvailableBytes(const fs::path& path) {
  std::error_code ec;
  fs::path existing = path;
  while (!existing.empty() && !fs::exists(existing, ec))
    existing = existing.parent_path();
  const fs::space_info space = fs::space(existing.empty() ? "." : existing, ec);
  if (ec) return std::nullopt;
  return space.available;
}

}  // namespace

bool DiskIsFull(const fs::path& path) {
  const std::optional<std::uintmax_t> available = AvailableBytes(path);
  return available && *available < kFullDiskBytes;
}

Error WriteFailure(const fs::path& path, const std::string& why) {
  const std::optional<std::uintmax_t> available = AvailableBytes(path);
  if (!available || *available >= kFullDiskBytes)
    return Error::In(path.string(), "could not be written: " + why);
  return Error::In(path.string(),
                   "could not be written: the disk holding it is full (" +
                       std::to_string(*available / 1024) +
                       " KiB free; the system said: " + why +
                       "); free some space and run the same command again "
                       "(what it wrote before is intact)");
}

void WriteAtomically(const fs::path& path,
                     const std::function<void(const fs::path&)>& write) {
  if (path.has_parent_path()) EnsureDirectory(path.parent_path());
  const fs::path tmp = TemporaryPathFor(path);
  try {
    write(tmp);
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) {
      throw Error::In(path.string(), "cannot replace it with " + tmp.string() +
                                         ": " + ec.message());
    }
  } catch (const fs::filesystem_error& e) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw WriteFailure(path, e.code().message());
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
}

void WriteFileAtomically(const fs::path& path, std::string_view bytes) {
  WriteAtomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) throw WriteFailure(path, std::strerror(errno));
  });
}

void EnsureDirectory(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec)
    throw Error::In(dir.string(), "cannot create directory: " + ec.message());
  if (!fs::is_directory(dir)) {
    throw Error::In(dir.string(), "exists but is not a directory");
  }
}

void CheckPlainName(const std::string& name, const std::string& source,
                    const std::string& field) {
  const char* problem = nullptr;
  if (name.empty() || name == "." || name == "..")
    problem = "is not a file name";
  else if (name.find('/') != std::string::npos ||
           name.find('\0') != std::string::npos)
    problem =
        "holds a '/' or NUL: a name read from a workspace may not "
        "name a path, least of all one outside the workspace";
  else if (name.size() > kMaxPlainNameBytes)
    problem = "is longer than the 200 bytes a name may have here";
  if (!problem) return;
  std::string shown = name.substr(0, 80);
  for (char& c : shown)
    if (c == '\0') c = '?';
  throw Error(source, field, shown + (name.size() > 80 ? "..." : ""), problem);
}

std::string ZeroPadded(std::int64_t value, int width) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%0*lld", width,
                static_cast<long long>(value));
  return buffer;
}

}  // namespace pano4d
