#pragma once

#include <filesystem>
#include <string>

namespace pano4d::testing {

// A fresh directory under the system temp dir, removed on destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const {
    return path_ / name;
  }

 private:
  std::filesystem::path path_;
};

// A tmpfs of `kib` KiB mounted on a fresh folder and unmounted on
// destruction, to fill a disk for real. Mounting needs root (CI runs as
// root); where it fails, mounted() is false and why() says why, for the
// test's loud skip.
class SmallDisk {
 public:
  explicit SmallDisk(int kib);
  ~SmallDisk();
  bool mounted() const { return mounted_; }
  const std::string& why() const { return why_; }
  const std::filesystem::path& path() const { return dir_.path(); }
  std::filesystem::path operator/(const std::string& name) const {
    return dir_ / name;
  }

 private:
  TempDir dir_;
  bool mounted_ = false;
  std::string why_;
};

// Writes a small valid PNG, then cuts it to half its size.
void WriteTruncatedPng(const std::filesystem::path& path);
void WriteText(const std::filesystem::path& path, const std::string& text);
// The file's bytes; empty when it cannot be read (a log a failed command
// did not write).
std::string Slurp(const std::filesystem::path& path);
// Runs `command` in a shell with stdout and stderr to `log`; returns its
// exit status (-1 when it did not exit normally).
int RunLogged(const std::string& command, const std::filesystem::path& log);
// Runs the built pano4d binary with `args` (as a shell splits them), as
// RunLogged does.
int RunPano4d(const std::string& args, const std::filesystem::path& log);

}  // namespace pano4d::testing
