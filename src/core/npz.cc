#include "src/core/npz.h"

#include <memory>
#include <sstream>
#include <vector>

#include <zip.h>

#include "src/core/error.h"
#include "src/core/file.h"

namespace pano4d {
namespace {

constexpr const char* kNpyExtension = ".npy";

std::string ZipErrorText(zip_error_t* error) {
  const std::string text = zip_error_strerror(error);
  zip_error_fini(error);
  return text;
}

struct ArchiveCloser {
  void operator()(zip_t* archive) const { zip_discard(archive); }
};
using Archive = std::unique_ptr<zip_t, ArchiveCloser>;

}  // namespace

NpzArrays ParseNpz(const std::uint8_t* bytes, std::size_t size,
                   const std::string& source) {
  zip_error_t error;
  zip_error_init(&error);
  zip_source_t* buffer = zip_source_buffer_create(bytes, size, 0, &error);
  if (!buffer) throw Error::In(source, "not readable: " + ZipErrorText(&error));
  Archive archive(zip_open_from_source(buffer, ZIP_RDONLY, &error));
  if (!archive) {
    zip_source_free(buffer);
    throw Error::In(source, "not an .npz (zip) archive: " +
                                ZipErrorText(&error));
  }
  zip_error_fini(&error);
  NpzArrays arrays;
  const zip_int64_t entries = zip_get_num_entries(archive.get(), 0);
  for (zip_int64_t i = 0; i < entries; ++i) {
    zip_stat_t stat;
    zip_stat_init(&stat);
    if (zip_stat_index(archive.get(), i, 0, &stat) != 0 ||
        !(stat.valid & ZIP_STAT_NAME) || !(stat.valid & ZIP_STAT_SIZE)) {
      throw Error(source, "entry", std::to_string(i), "unreadable zip entry");
    }
    std::string name = stat.name;
    const std::string entry = source + ":" + name;
    if ((stat.valid & ZIP_STAT_ENCRYPTION_METHOD) &&
        stat.encryption_method != ZIP_EM_NONE) {
      throw Error::In(entry, "is encrypted");
    }
    if ((stat.valid & ZIP_STAT_COMP_METHOD) &&
        stat.comp_method != ZIP_CM_STORE &&
        stat.comp_method != ZIP_CM_DEFLATE) {
      throw Error(entry, "compression", std::to_string(stat.comp_method),
                  "not stored or deflated (np.savez / np.savez_compressed)");
    }
    if (stat.size > kMaxNpzEntryBytes) {
      throw Error(entry, "size", std::to_string(stat.size),
                  "larger than " + std::to_string(kMaxNpzEntryBytes) +
                      " bytes");
    }
    if (name.ends_with(kNpyExtension))
      name.resize(name.size() - std::string(kNpyExtension).size());
    std::vector<std::uint8_t> data(stat.size);
    zip_file_t* file = zip_fopen_index(archive.get(), i, 0);
    if (!file) {
      throw Error::In(entry,
                      std::string("cannot open: ") + zip_strerror(archive.get()));
    }
    zip_int64_t got = data.empty() ? 0 : zip_fread(file, data.data(), data.size());
    // One more byte than the header announced means the entry lies about
    // its size; libzip's CRC check runs at the end of the data.
    std::uint8_t extra;
    const zip_int64_t more = zip_fread(file, &extra, 1);
    const std::string problem = zip_file_strerror(file);
    zip_fclose(file);
    if (got < 0 || more < 0 || got != static_cast<zip_int64_t>(data.size()) ||
        more != 0) {
      throw Error::In(entry, "truncated or corrupt (" + problem + ")");
    }
    arrays[name] = ParseNpy(data.data(), data.size(), entry);
  }
  return arrays;
}

NpzArrays ReadNpz(const std::filesystem::path& path) {
  const std::vector<std::uint8_t> bytes = ReadFileBytes(path);
  return ParseNpz(bytes.data(), bytes.size(), path.string());
}

void WriteNpz(const std::filesystem::path& path, const NpzArrays& arrays,
              bool compressed) {
  // The entries' bytes must outlive zip_close, which writes them.
  std::vector<std::string> blobs;
  blobs.reserve(arrays.size());
  for (const auto& [name, array] : arrays) {
    std::ostringstream out;
    WriteNpy(out, array);
    blobs.push_back(out.str());
  }
  WriteAtomically(path, [&](const std::filesystem::path& tmp) {
    int code = 0;
    zip_t* archive = zip_open(tmp.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &code);
    if (!archive) {
      zip_error_t error;
      zip_error_init_with_code(&error, code);
      throw Error::In(path.string(), "cannot write: " + ZipErrorText(&error));
    }
    const auto fail = [&](const std::string& what) {
      const std::string text = what + ": " + zip_strerror(archive);
      zip_discard(archive);
      throw Error::In(path.string(), text);
    };
    std::size_t b = 0;
    for (const auto& entry : arrays) {
      const std::string& blob = blobs[b++];
      zip_source_t* source =
          zip_source_buffer(archive, blob.data(), blob.size(), 0);
      if (!source) fail("cannot add " + entry.first);
      const zip_int64_t index =
          zip_file_add(archive, (entry.first + kNpyExtension).c_str(), source,
                       ZIP_FL_OVERWRITE);
      if (index < 0) {
        zip_source_free(source);
        fail("cannot add " + entry.first);
      }
      if (zip_set_file_compression(archive, index,
                                   compressed ? ZIP_CM_DEFLATE : ZIP_CM_STORE,
                                   0) != 0)
        fail("cannot set the compression of " + entry.first);
    }
    if (zip_close(archive) != 0) fail("cannot write");
  });
}

const NpyArray& NpzArray(const NpzArrays& arrays, const std::string& key,
                         const std::string& source) {
  const auto it = arrays.find(key);
  if (it != arrays.end()) return it->second;
  std::string keys;
  for (const auto& [name, array] : arrays)
    keys += (keys.empty() ? "" : ", ") + name;
  throw Error(source, "key", key,
              "missing; the archive holds " +
                  (keys.empty() ? std::string("no arrays") : keys));
}

}  // namespace pano4d
