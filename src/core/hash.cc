#include "src/core/hash.h"

#include <cstdio>
#include <cstring>
#include <fstream>

#include "src/core/error.h"

namespace pano4d {
namespace {

constexpr std::uint64_t kMultiplier = 0x9e3779b97f4a7c15ULL;  // 2^64 / phi

// One 64-bit word into the state: multiply-xorshift (as splitmix64), so
// that every input bit reaches every state bit within two words.
std::uint64_t Mix(std::uint64_t state, std::uint64_t word) {
  state = (state ^ word) * kMultiplier;
  return state ^ (state >> 29);
}

}  // namespace

void Hash64::Add(const void* data, std::size_t size) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  length_ += size;
  while (size > 0 && pending_size_ > 0) {
    pending_[pending_size_++] = *bytes++;
    --size;
    if (pending_size_ == 8) {
      std::uint64_t word;
      std::memcpy(&word, pending_, 8);
      state_ = Mix(state_, word);
      pending_size_ = 0;
    }
  }
  if (pending_size_ > 0) return;  // all of `data` went to pending_
  for (; size >= 8; bytes += 8, size -= 8) {
    std::uint64_t word;
    std::memcpy(&word, bytes, 8);
    state_ = Mix(state_, word);
  }
  std::memcpy(pending_, bytes, size);
  pending_size_ = size;
}

std::uint64_t Hash64::value() const {
  std::uint64_t tail = 0;
  std::memcpy(&tail, pending_, pending_size_);
  std::uint64_t h = Mix(Mix(state_, tail), length_);
  h ^= h >> 31;
  h *= 0xbf58476d1ce4e5b9ULL;
  return h ^ (h >> 32);
}

std::string Hash64::Hex() const {
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx",
                static_cast<unsigned long long>(value()));
  return text;
}

std::string HashFileHex(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error::In(path.string(), "cannot be read");
  Hash64 hash;
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    hash.Add(buffer.data(), static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) throw Error::In(path.string(), "read failed");
  return hash.Hex();
}

}  // namespace pano4d
