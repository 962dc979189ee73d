#include "colmap_ext/model_io_binary.h"

#include <bit>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <sstream>

#include "colmap_ext/model_file.h"
#include "src/core/error.h"
#include "src/core/file.h"

namespace pano4d {
namespace {

static_assert(std::endian::native == std::endian::little,
              "COLMAP's binary files are little-endian, as is this machine");

// The fewest bytes an entry can take, to refuse counts that the rest of the
// stream cannot hold before reserving memory for them.
constexpr std::uint64_t kMinCameraBytes = 4 + 4 + 8 + 8 + 3 * 8;  // 3 params
constexpr std::uint64_t kMinImageBytes = 4 + 7 * 8 + 4 + 1 + 8;   // name ""
constexpr std::uint64_t kPoint2DBytes = 8 + 8 + 8;
constexpr std::uint64_t kMinPoint3DBytes = 8 + 3 * 8 + 3 + 8 + 8;
constexpr std::uint64_t kTrackElementBytes = 4 + 4;

std::string Id(std::uint64_t id) { return std::to_string(id); }

// Reads little-endian fields from a stream whose size is known up front.
// Field names are built by callables only when an error is thrown, which
// keeps the hot loops free of string formatting.
class BinaryReader {
 public:
  BinaryReader(std::istream& stream, const std::string& source)
      : stream_(&stream), source_(source) {
    const std::istream::pos_type start = stream.tellg();
    if (start != std::istream::pos_type(-1) && stream.seekg(0, std::ios::end)) {
      const std::istream::pos_type end = stream.tellg();
      stream.seekg(start);
      if (end != std::istream::pos_type(-1) && stream) {
        size_ = static_cast<std::uint64_t>(end - start);
        return;
      }
    }
    // Not seekable (a pipe): the size is only known once it is read.
    stream.clear();
    owned_ = std::make_unique<std::istringstream>(
        std::string(std::istreambuf_iterator<char>(stream), {}));
    stream_ = owned_.get();
    size_ = owned_->str().size();
  }

  std::uint64_t offset() const { return offset_; }
  std::uint64_t remaining() const { return size_ - offset_; }

  template <typename T, typename Field>
  T Read(const Field& field) {
    T value;
    ReadBytes(reinterpret_cast<char*>(&value), sizeof(T), field);
    return value;
  }

  // A count of entries of at least `min_bytes` each, refused when the rest of
  // the stream cannot hold that many.
  template <typename Field>
  std::uint64_t ReadCount(std::uint64_t min_bytes, const Field& field) {
    const std::uint64_t at = offset_;
    const auto count = Read<std::uint64_t>(field);
    if (count > remaining() / min_bytes) {
      throw Error(source_, field(), Id(count),
                  "count at byte " + Id(at) + " needs at least " +
                      (count > UINT64_MAX / min_bytes ? std::string("2^64")
                                                      : Id(count * min_bytes)) +
                      " more bytes, but only " + Id(remaining()) +
                      " remain of " + Id(size_));
    }
    return count;
  }

  // A NUL-terminated string, as COLMAP writes image names.
  template <typename Field>
  std::string ReadName(const Field& field) {
    std::string name;
    while (true) {
      if (remaining() == 0) {
        throw Error(source_, field(), "byte " + Id(offset_),
                    "truncated at byte " + Id(size_) + " of " + Id(size_) +
                        ": the name has no terminating NUL");
      }
      const int c = stream_->get();
      if (c == std::char_traits<char>::eof()) Truncated(1, field);
      ++offset_;
      if (c == '\0') return name;
      name.push_back(static_cast<char>(c));
    }
  }

  template <typename Field>
  void ExpectEnd(const Field& last_entry) {
    if (remaining() == 0) return;
    throw Error(source_, "", "byte " + Id(offset_),
                Id(remaining()) + " unexpected bytes after " + last_entry() +
                    " (the file has " + Id(size_) + " bytes)");
  }

 private:
  template <typename Field>
  void ReadBytes(char* data, std::uint64_t n, const Field& field) {
    if (n > remaining()) Truncated(n, field);
    stream_->read(data, static_cast<std::streamsize>(n));
    // The stream can still come up short if the file shrank under us.
    if (static_cast<std::uint64_t>(stream_->gcount()) != n) Truncated(n, field);
    offset_ += n;
  }

  template <typename Field>
  [[noreturn]] void Truncated(std::uint64_t n, const Field& field) {
    throw Error(source_, field(), "byte " + Id(offset_),
                "truncated at byte " + Id(offset_ + n) + " of " + Id(size_) +
                    ": the field needs " + Id(n) + " bytes");
  }

  std::istream* stream_;
  std::unique_ptr<std::istringstream> owned_;
  const std::string& source_;
  std::uint64_t offset_ = 0;
  std::uint64_t size_ = 0;
};

class BinaryWriter {
 public:
  explicit BinaryWriter(std::ostream& stream) : stream_(stream) {}
  template <typename T>
  void Write(T value) {
    stream_.write(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  void WriteName(const std::string& name) {
    stream_.write(name.c_str(), static_cast<std::streamsize>(name.size() + 1));
  }

 private:
  std::ostream& stream_;
};

void CheckWritten(std::ostream& stream, const char* what) {
  if (!stream) {
    throw Error::In(what, "writing the binary model to the stream failed");
  }
}

}  // namespace

void ReadCamerasBinary(ColmapModel& model, std::istream& stream,
                       const std::string& source) {
  BinaryReader reader(stream, source);
  const std::uint64_t count =
      reader.ReadCount(kMinCameraBytes, [] { return "num_cameras"; });
  std::vector<ColmapCamera> cameras;
  cameras.reserve(count);
  for (std::uint64_t i = 0; i < count; ++i) {
    ColmapCamera& camera = cameras.emplace_back();
    camera.camera_id = reader.Read<std::uint32_t>(
        [&] { return "camera_id of camera number " + Id(i + 1); });
    const auto field = [&](const char* name) {
      return [&camera, name] {
        return "camera " + Id(camera.camera_id) + " " + name;
      };
    };
    const std::uint64_t model_at = reader.offset();
    camera.model_id = reader.Read<std::int32_t>(field("model_id"));
    const std::optional<CameraModelId> model_id =
        CameraModelFromId(camera.model_id);
    if (!model_id) {
      throw Error(source, field("model_id")(), std::to_string(camera.model_id),
                  "at byte " + Id(model_at) +
                      ": not a COLMAP 3.8 camera model id (0 to 10)");
    }
    camera.width = reader.Read<std::uint64_t>(field("width"));
    camera.height = reader.Read<std::uint64_t>(field("height"));
    camera.params.resize(GetCameraModelInfo(*model_id).num_params);
    for (double& param : camera.params) {
      param = reader.Read<double>(field("params"));
    }
  }
  reader.ExpectEnd([&] { return "the last camera"; });
  model.cameras = std::move(cameras);
  model.BuildIndex();
}

void ReadImagesBinary(ColmapModel& model, std::istream& stream,
                      const std::string& source) {
  BinaryReader reader(stream, source);
  const std::uint64_t count =
      reader.ReadCount(kMinImageBytes, [] { return "num_images"; });
  std::vector<ColmapImage> images;
  images.reserve(count);
  for (std::uint64_t i = 0; i < count; ++i) {
    ColmapImage& image = images.emplace_back();
    image.image_id = reader.Read<std::uint32_t>(
        [&] { return "image_id of image number " + Id(i + 1); });
    const auto field = [&](const char* name) {
      return
          [&image, name] { return "image " + Id(image.image_id) + " " + name; };
    };
    for (int k = 0; k < 4; ++k)
      image.qvec(k) = reader.Read<double>(field("qvec"));
    for (int k = 0; k < 3; ++k)
      image.tvec(k) = reader.Read<double>(field("tvec"));
    image.camera_id = reader.Read<std::uint32_t>(field("camera_id"));
    image.name = reader.ReadName(field("name"));
    const std::uint64_t num_points =
        reader.ReadCount(kPoint2DBytes, field("num_points2D"));
    image.points2D.resize(num_points);
    for (std::uint64_t j = 0; j < num_points; ++j) {
      const auto point_field = [&](const char* name) {
        return [&image, j, name] {
          return "image " + Id(image.image_id) + " point2D " + Id(j) + " " +
                 name;
        };
      };
      ColmapPoint2D& point = image.points2D[j];
      point.xy.x() = reader.Read<double>(point_field("x"));
      point.xy.y() = reader.Read<double>(point_field("y"));
      point.point3D_id = reader.Read<std::uint64_t>(point_field("point3D_id"));
    }
  }
  reader.ExpectEnd([&] { return "the last image"; });
  model.images = std::move(images);
  model.BuildIndex();
}

void ReadPoints3DBinary(ColmapModel& model, std::istream& stream,
                        const std::string& source) {
  BinaryReader reader(stream, source);
  const std::uint64_t count =
      reader.ReadCount(kMinPoint3DBytes, [] { return "num_points3D"; });
  std::vector<ColmapPoint3D> points;
  points.reserve(count);
  for (std::uint64_t i = 0; i < count; ++i) {
    ColmapPoint3D& point = points.emplace_back();
    point.point3D_id = reader.Read<std::uint64_t>(
        [&] { return "point3D_id of point number " + Id(i + 1); });
    const auto field = [&](const char* name) {
      return [&point, name] {
        return "point3D " + Id(point.point3D_id) + " " + name;
      };
    };
    for (int k = 0; k < 3; ++k)
      point.xyz(k) = reader.Read<double>(field("xyz"));
    for (std::uint8_t& c : point.rgb)
      c = reader.Read<std::uint8_t>(field("rgb"));
    point.error = reader.Read<double>(field("error"));
    const std::uint64_t length =
        reader.ReadCount(kTrackElementBytes, field("track_length"));
    point.track.resize(length);
    for (std::uint64_t k = 0; k < length; ++k) {
      const auto element_field = [&](const char* name) {
        return [&point, k, name] {
          return "point3D " + Id(point.point3D_id) + " track element " + Id(k) +
                 " " + name;
        };
      };
      point.track[k].image_id =
          reader.Read<std::uint32_t>(element_field("image_id"));
      point.track[k].point2D_idx =
          reader.Read<std::uint32_t>(element_field("point2D_idx"));
    }
  }
  reader.ExpectEnd([&] { return "the last point3D"; });
  model.points3D = std::move(points);
  model.BuildIndex();
}

void ReadCamerasBinary(ColmapModel& model, const std::filesystem::path& path) {
  ReadModelFile(path, [&](std::istream& stream, const std::string& source) {
    ReadCamerasBinary(model, stream, source);
  });
}

void ReadImagesBinary(ColmapModel& model, const std::filesystem::path& path) {
  ReadModelFile(path, [&](std::istream& stream, const std::string& source) {
    ReadImagesBinary(model, stream, source);
  });
}

void ReadPoints3DBinary(ColmapModel& model, const std::filesystem::path& path) {
  ReadModelFile(path, [&](std::istream& stream, const std::string& source) {
    ReadPoints3DBinary(model, stream, source);
  });
}

void WriteCamerasBinary(const ColmapModel& model, std::ostream& stream) {
  for (const ColmapCamera& camera : model.cameras) {
    CheckedCameraModel(camera, "cameras.bin");
  }
  BinaryWriter writer(stream);
  writer.Write<std::uint64_t>(model.cameras.size());
  for (const ColmapCamera& camera : model.cameras) {
    writer.Write<std::uint32_t>(camera.camera_id);
    writer.Write<std::int32_t>(camera.model_id);
    writer.Write<std::uint64_t>(camera.width);
    writer.Write<std::uint64_t>(camera.height);
    for (const double param : camera.params) writer.Write<double>(param);
  }
  CheckWritten(stream, "cameras.bin");
}

void WriteImagesBinary(const ColmapModel& model, std::ostream& stream) {
  for (const ColmapImage& image : model.images) {
    if (image.name.find('\0') != std::string::npos) {
      throw Error("images.bin", "image " + Id(image.image_id) + " name", "",
                  "contains a NUL byte, which ends a name in images.bin");
    }
  }
  BinaryWriter writer(stream);
  writer.Write<std::uint64_t>(model.images.size());
  for (const ColmapImage& image : model.images) {
    writer.Write<std::uint32_t>(image.image_id);
    for (int k = 0; k < 4; ++k) writer.Write<double>(image.qvec(k));
    for (int k = 0; k < 3; ++k) writer.Write<double>(image.tvec(k));
    writer.Write<std::uint32_t>(image.camera_id);
    writer.WriteName(image.name);
    writer.Write<std::uint64_t>(image.points2D.size());
    for (const ColmapPoint2D& point : image.points2D) {
      writer.Write<double>(point.xy.x());
      writer.Write<double>(point.xy.y());
      writer.Write<std::uint64_t>(point.point3D_id);
    }
  }
  CheckWritten(stream, "images.bin");
}

void WritePoints3DBinary(const ColmapModel& model, std::ostream& stream) {
  BinaryWriter writer(stream);
  writer.Write<std::uint64_t>(model.points3D.size());
  for (const ColmapPoint3D& point : model.points3D) {
    writer.Write<std::uint64_t>(point.point3D_id);
    for (int k = 0; k < 3; ++k) writer.Write<double>(point.xyz(k));
    for (const std::uint8_t c : point.rgb) writer.Write<std::uint8_t>(c);
    writer.Write<double>(point.error);
    writer.Write<std::uint64_t>(point.track.size());
    for (const ColmapTrackElement& element : point.track) {
      writer.Write<std::uint32_t>(element.image_id);
      writer.Write<std::uint32_t>(element.point2D_idx);
    }
  }
  CheckWritten(stream, "points3D.bin");
}

void WriteCamerasBinary(const ColmapModel& model,
                        const std::filesystem::path& path) {
  WriteModelFile(
      path, [&](std::ostream& stream) { WriteCamerasBinary(model, stream); });
}

void WriteImagesBinary(const ColmapModel& model,
                       const std::filesystem::path& path) {
  WriteModelFile(
      path, [&](std::ostream& stream) { WriteImagesBinary(model, stream); });
}

void WritePoints3DBinary(const ColmapModel& model,
                         const std::filesystem::path& path) {
  WriteModelFile(
      path, [&](std::ostream& stream) { WritePoints3DBinary(model, stream); });
}

}  // namespace pano4d
