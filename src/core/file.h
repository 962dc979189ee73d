#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "src/core/error.h"

namespace pano4d {

// Whole-file reads that throw pano4d::Error naming the path when the file is
// missing, is a directory, or cannot be read.
std::vector<std::uint8_t> ReadFileBytes(const std::filesystem::path& path);
std::string ReadTextFile(const std::filesystem::path& path);

// The temporary name that WriteAtomically uses for `path`: same directory and
// extension (encoders such as OpenCV's choose the format by extension), with a
// process-unique infix, e.g. "frame.png" -> "frame.tmp.1234.7.png".
std::filesystem::path TemporaryPathFor(const std::filesystem::path& path);

// Writes through `write(tmp)` to a temporary file, then renames it onto
// `path`, so a reader never sees a half-written file and a killed run leaves
// the previous version intact. Creates the parent directory. If `write`
// throws, the temporary is removed and the exception propagates (a
// std::filesystem error as a WriteFailure naming `path`).
void WriteAtomically(
    const std::filesystem::path& path,
    const std::function<void(const std::filesystem::path&)>& write);
void WriteFileAtomically(const std::filesystem::path& path,
                         std::string_view bytes);

// Less room than this on a file system after a write failed there: the disk
// is taken to be full. A write that fills a disk leaves a little room free
// (blocks it could not use, space reserved for root), so the test is not
// "zero bytes".
inline constexpr std::uintmax_t kFullDiskBytes = std::uintmax_t{1} << 20;

// Whether the file system holding `path` (or its nearest existing parent)
// has less than kFullDiskBytes available; false when that cannot be told.
bool DiskIsFull(const std::filesystem::path& path);

// The Error for a failed write of `path`, `why` being the system's reason.
// A full disk does not always read as such (a copy through sendfile reports
// "Input/output error", OpenCV reports nothing), so when DiskIsFull the
// message says so, with the room left, and what to do.
Error WriteFailure(const std::filesystem::path& path, const std::string& why);

// Removes the temporaries that WriteAtomically left under `dir` (recursive)
// when its process was killed: files named like TemporaryPathFor's whose
// process id no longer runs (a live process may still be writing). Logs
// and returns the count; a file that cannot be removed is left and not
// counted. `fit`, `depth` and `run` call it on their workspace first.
int RemoveLeftoverTemporaries(const std::filesystem::path& dir);

// A folder of many files written by one command (export, render, view):
// while the command runs, `dir`/INCOMPLETE says so (and which command), so
// that a folder an interrupted run left, its new files beside an earlier
// run's, is never taken for a finished one. The constructor first removes
// the temporaries a killed run left there and every file of an earlier
// output that matches `stale` (a regex on the path relative to `dir`, for
// the numbered files a shorter new output would not overwrite);
// Complete() removes the marker.
class OutputFolder {
 public:
  OutputFolder(std::filesystem::path dir, const std::string& command,
               const std::string& stale = "");
  void Complete();
  const std::filesystem::path& dir() const { return dir_; }
  static constexpr const char* kMarker = "INCOMPLETE";

 private:
  std::filesystem::path dir_;
};

// Creates `dir` (and parents) or throws an Error naming it.
void EnsureDirectory(const std::filesystem::path& dir);

// Names read from a workspace file (frame names in frames.json) become
// file names inside the workspace (renders/val/<name>.png, depth/<name>
// .npy): throws an Error naming `source` and `field` unless `name` is one
// plain file name, not empty, without '/' or NUL, not "." or "..", and at
// most kMaxPlainNameBytes long (room for a suffix and an extension within
// the 255 bytes a file name may have), so that none of them can name a
// path outside the workspace or one the system refuses.
inline constexpr std::size_t kMaxPlainNameBytes = 200;
void CheckPlainName(const std::string& name, const std::string& source,
                    const std::string& field);

// `value` with leading zeros to `width` digits, for file names that sort
// (5: frames and times, "00042"; 2: expansion steps, "03").
std::string ZeroPadded(std::int64_t value, int width);

}  // namespace pano4d
