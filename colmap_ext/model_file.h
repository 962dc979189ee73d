#pragma once
// Internal to colmap_ext: the file side of the model readers and writers,
// shared by the binary and the text format.
#include <filesystem>
#include <functional>
#include <istream>
#include <ostream>
#include <string>

namespace pano4d {

// Opens `path` and calls read(stream, source name). Throws pano4d::Error
// naming the path when it is a directory or cannot be opened.
void ReadModelFile(
    const std::filesystem::path& path,
    const std::function<void(std::istream&, const std::string&)>& read);

// Writes `path` atomically through write(stream); an Error from `write` is
// re-thrown naming `path`. Bytes are written as given (no newline
// translation), so text files are byte-exact on every platform.
void WriteModelFile(const std::filesystem::path& path,
                    const std::function<void(std::ostream&)>& write);

}  // namespace pano4d
