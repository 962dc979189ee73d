#include "tests/support/test_files.h"

#include <sys/mount.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>

#include "src/core/file.h"
#include "src/core/image.h"

namespace pano4d::testing {

TempDir::TempDir() {
  std::random_device rd;
  path_ = std::filesystem::temp_directory_path() /
          ("pano4d_test_" + std::to_string(rd()) + std::to_string(rd()));
  std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

SmallDisk::SmallDisk(int kib) {
  const std::string options = "size=" + std::to_string(kib) + "k";
  mounted_ =
      ::mount("tmpfs", dir_.path().c_str(), "tmpfs", 0, options.c_str()) == 0;
  if (!mounted_) {
    why_ = "mounting a " + std::to_string(kib) + " KiB tmpfs on " +
           dir_.path().string() + " failed (" + std::strerror(errno) +
           "): the test needs root";
  }
}

SmallDisk::~SmallDisk() {
  if (mounted_) ::umount2(dir_.path().c_str(), MNT_DETACH);
}

void WriteTruncatedPng(const std::filesystem::path& path) {
  Image image(32, 24);
  image.mat().setTo(cv::Scalar(0.2, 0.5, 0.8));
  const std::vector<std::uint8_t> bytes =
      EncodeImage(image, ".png", path.string());
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size() / 2));
}

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

std::string Slurp(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

int RunLogged(const std::string& command, const std::filesystem::path& log) {
  const int raw =
      std::system((command + " > '" + log.string() + "' 2>&1").c_str());
  return WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
}

int RunPano4d(const std::string& args, const std::filesystem::path& log) {
  return RunLogged(std::string(PANO4D_BINARY_DIR) + "/pano4d " + args, log);
}

}  // namespace pano4d::testing
