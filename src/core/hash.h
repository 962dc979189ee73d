#pragma once

// A 64-bit content hash for noticing change and corruption (checkpoint
// checksums, the scene a checkpoint belongs to, stage stamps): fast enough to
// run over every byte a fit holds, not a cryptographic digest.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace pano4d {

class Hash64 {
 public:
  // Feeds bytes; feeding A then B equals feeding A+B.
  void Add(const void* data, std::size_t size);
  void Add(std::string_view text) { Add(text.data(), text.size()); }
  // A value's bytes (a number, a float array) and a string's length first,
  // so that ("ab", "c") and ("a", "bc") differ.
  template <typename T>
  void AddValue(const T& value) {
    Add(&value, sizeof(T));
  }
  template <typename T>
  void AddArray(const std::vector<T>& values) {
    AddValue(values.size());
    Add(values.data(), values.size() * sizeof(T));
  }
  void AddString(std::string_view text) {
    AddValue(text.size());
    Add(text);
  }

  std::uint64_t value() const;
  std::string Hex() const;  // 16 lower-case hex digits

 private:
  std::uint64_t state_ = 0x243f6a8885a308d3ULL;  // pi's fraction bits
  std::uint64_t length_ = 0;
  unsigned char pending_[8] = {};
  std::size_t pending_size_ = 0;
};

// The hash of a whole file (Error naming it when it cannot be read).
std::string HashFileHex(const std::filesystem::path& path);

}  // namespace pano4d
