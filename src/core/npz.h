#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include "src/core/npy.h"

namespace pano4d {

// A NumPy .npz archive: a zip of .npy files, as np.savez writes it (entries
// stored) or np.savez_compressed (entries deflated). Arrays are keyed by
// their name without ".npy" (np.load's keys). Read through libzip.
using NpzArrays = std::map<std::string, NpyArray>;

// Guard against a crafted archive: an entry may not announce more bytes
// than this (4 GiB: a float32 flow of 16k x 16k pixels), checked before
// anything is allocated.
inline constexpr std::uint64_t kMaxNpzEntryBytes = std::uint64_t{1} << 32;

// Throws pano4d::Error naming `source` (and the entry) when the bytes are
// not a zip archive, an entry is encrypted, compressed with a method other
// than deflate, larger than its header says, or not a valid .npy.
NpzArrays ParseNpz(const std::uint8_t* bytes, std::size_t size,
                   const std::string& source);
NpzArrays ReadNpz(const std::filesystem::path& path);

// Writes atomically; `compressed` deflates each entry (np.savez_compressed)
// instead of storing it (np.savez).
void WriteNpz(const std::filesystem::path& path, const NpzArrays& arrays,
              bool compressed = false);

// The array `key` of an archive read from `source`; throws pano4d::Error
// naming the file, the key and the keys it does hold when it is missing.
const NpyArray& NpzArray(const NpzArrays& arrays, const std::string& key,
                         const std::string& source);

}  // namespace pano4d
