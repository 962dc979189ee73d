#include "colmap_ext/model_io_text.h"

#include <charconv>
#include <fstream>
#include <limits>

#include "colmap_ext/model_file.h"
#include "src/core/error.h"
#include "src/core/file.h"

namespace pano4d {
namespace {

std::string Id(std::uint64_t id) { return std::to_string(id); }

// The blanks COLMAP's StringTrim removes; '\r' among them, so files with
// Windows line ends read the same.
bool IsBlank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

std::string_view Trim(std::string_view text) {
  while (!text.empty() && IsBlank(text.front())) text.remove_prefix(1);
  while (!text.empty() && IsBlank(text.back())) text.remove_suffix(1);
  return text;
}

// Splits `line` at runs of blanks into `tokens`, stopping after `max_tokens`.
void Split(std::string_view line, std::vector<std::string_view>& tokens,
           std::size_t max_tokens = std::numeric_limits<std::size_t>::max()) {
  tokens.clear();
  std::size_t i = 0;
  while (i < line.size() && tokens.size() < max_tokens) {
    while (i < line.size() && IsBlank(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !IsBlank(line[i])) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
}

std::string Quoted(std::string_view token) {
  constexpr std::size_t kMaxShown = 40;  // a runaway token stays one line
  // Appended piece by piece: GCC 12 warns falsely (-Wrestrict) on
  // "literal" + std::string here.
  std::string quoted(1, '"');
  quoted.append(token.substr(0, kMaxShown));
  if (token.size() > kMaxShown) quoted.append("...");
  quoted.push_back('"');
  return quoted;
}

// Reads lines and turns tokens into numbers; errors name "source:line".
class LineReader {
 public:
  LineReader(std::istream& stream, const std::string& source)
      : stream_(stream), source_(source) {}

  // The next line that is neither empty nor a comment, trimmed.
  bool NextRecord(std::string_view& line) {
    while (NextLine(line)) {
      if (!line.empty() && line.front() != '#') return true;
    }
    return false;
  }

  // The very next line, trimmed, whatever it holds.
  bool NextLine(std::string_view& line) {
    if (!std::getline(stream_, buffer_)) return false;
    ++line_number_;
    line = Trim(buffer_);
    return true;
  }

  std::string Where() const { return source_ + ":" + Id(line_number_); }

  template <typename Field>
  [[noreturn]] void Fail(const Field& field, std::string value,
                         const std::string& problem) const {
    throw Error(Where(), field(), std::move(value), problem);
  }

  template <typename Field>
  double Real(std::string_view token, const Field& field) const {
    double value = 0.0;
    const std::string_view digits = WithoutPlus(token);
    const auto [end, error] =
        std::from_chars(digits.data(), digits.data() + digits.size(), value);
    // Out of range is refused too: COLMAP's std::stold would throw.
    if (error != std::errc() || end != digits.data() + digits.size()) {
      Fail(field, Quoted(token), "expected a real number");
    }
    return value;
  }

  template <typename T, typename Field>
  T Unsigned(std::string_view token, const Field& field) const {
    T value = 0;
    const std::string_view digits = WithoutPlus(token);
    const auto [end, error] =
        std::from_chars(digits.data(), digits.data() + digits.size(), value);
    if (error != std::errc() || end != digits.data() + digits.size()) {
      Fail(
          field, Quoted(token),
          "expected an integer from 0 to " + Id(std::numeric_limits<T>::max()));
    }
    return value;
  }

 private:
  // COLMAP reads numbers with std::stod and friends, which take a '+'.
  static std::string_view WithoutPlus(std::string_view token) {
    if (token.size() > 1 && token[0] == '+' && token[1] != '-' &&
        token[1] != '+') {
      token.remove_prefix(1);
    }
    return token;
  }

  std::istream& stream_;
  const std::string& source_;
  std::string buffer_;
  std::uint64_t line_number_ = 0;
};

// Numbers as COLMAP's streams print them at precision 17: to_chars with a
// precision is specified as printf's %.17g in the C locale, which is what
// std::ostream uses, without depending on the global locale.
void AppendReal(std::string& out, double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value,
                                    std::chars_format::general, 17);
  out.append(buffer, result.ptr);
}

void AppendInt(std::string& out, std::uint64_t value) {
  char buffer[24];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out.append(buffer, result.ptr);
}

void CheckWritten(std::ostream& stream, const char* what) {
  if (!stream) {
    throw Error::In(what, "writing the text model to the stream failed");
  }
}

}  // namespace

void ReadCamerasText(ColmapModel& model, std::istream& stream,
                     const std::string& source) {
  LineReader reader(stream, source);
  std::vector<ColmapCamera> cameras;
  std::vector<std::string_view> tokens;
  std::string_view line;
  while (reader.NextRecord(line)) {
    Split(line, tokens);
    const auto field = [&](const std::string& name) {
      return [&, name] {
        return tokens.empty() ? name
                              : "camera " + std::string(tokens[0]) + " " + name;
      };
    };
    if (tokens.size() < 4) {
      reader.Fail(field("line"), Id(tokens.size()) + " values",
                  "expected CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]");
    }
    ColmapCamera camera;
    camera.camera_id = reader.Unsigned<std::uint32_t>(
        tokens[0], [] { return std::string("CAMERA_ID"); });
    const std::optional<CameraModelId> model_id =
        CameraModelFromName(tokens[1]);
    if (!model_id) {
      reader.Fail(field("MODEL"), Quoted(tokens[1]),
                  "not a COLMAP 3.8 camera model name");
    }
    const CameraModelInfo& info = GetCameraModelInfo(*model_id);
    camera.model_id = static_cast<int>(*model_id);
    camera.width = reader.Unsigned<std::uint64_t>(tokens[2], field("WIDTH"));
    camera.height = reader.Unsigned<std::uint64_t>(tokens[3], field("HEIGHT"));
    if (tokens.size() - 4 != static_cast<std::size_t>(info.num_params)) {
      reader.Fail(field("PARAMS"), Id(tokens.size() - 4) + " values",
                  std::string(info.name) + " takes " + Id(info.num_params));
    }
    for (std::size_t k = 4; k < tokens.size(); ++k) {
      camera.params.push_back(
          reader.Real(tokens[k], field("PARAMS[" + Id(k - 4) + "]")));
    }
    cameras.push_back(std::move(camera));
  }
  model.cameras = std::move(cameras);
  model.BuildIndex();
}

void ReadImagesText(ColmapModel& model, std::istream& stream,
                    const std::string& source) {
  static constexpr const char* kPoseFields[] = {"QW", "QX", "QY", "QZ",
                                                "TX", "TY", "TZ"};
  LineReader reader(stream, source);
  std::vector<ColmapImage> images;
  std::vector<std::string_view> tokens;
  std::string_view line;
  while (reader.NextRecord(line)) {
    ColmapImage& image = images.emplace_back();
    const auto field = [&](std::string name) {
      return
          [&image, name] { return "image " + Id(image.image_id) + " " + name; };
    };
    // The name is the rest of the line after the ninth token.
    Split(line, tokens, 9);
    if (tokens.size() < 9) {
      reader.Fail([] { return std::string("line"); },
                  Id(tokens.size()) + " values",
                  "expected IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, "
                  "CAMERA_ID, NAME");
    }
    image.image_id = reader.Unsigned<std::uint32_t>(
        tokens[0], [] { return std::string("IMAGE_ID"); });
    for (int k = 0; k < 4; ++k) {
      image.qvec(k) = reader.Real(tokens[1 + k], field(kPoseFields[k]));
    }
    for (int k = 0; k < 3; ++k) {
      image.tvec(k) = reader.Real(tokens[5 + k], field(kPoseFields[4 + k]));
    }
    image.camera_id =
        reader.Unsigned<std::uint32_t>(tokens[8], field("CAMERA_ID"));
    const std::size_t name_start =
        static_cast<std::size_t>(tokens[8].data() - line.data()) +
        tokens[8].size();
    image.name = std::string(Trim(line.substr(name_start)));

    if (!reader.NextLine(line)) {
      reader.Fail(field("POINTS2D"), "",
                  "the file ends after the image line; every image needs a "
                  "POINTS2D line, possibly empty");
    }
    Split(line, tokens);
    if (tokens.size() % 3 != 0) {
      reader.Fail(field("POINTS2D"), Id(tokens.size()) + " values",
                  "expected triples X, Y, POINT3D_ID");
    }
    image.points2D.resize(tokens.size() / 3);
    for (std::size_t j = 0; j < image.points2D.size(); ++j) {
      const std::string at = "point2D " + Id(j);
      ColmapPoint2D& point = image.points2D[j];
      point.xy.x() = reader.Real(tokens[3 * j], field(at + " X"));
      point.xy.y() = reader.Real(tokens[3 * j + 1], field(at + " Y"));
      const std::string_view id = tokens[3 * j + 2];
      point.point3D_id = id == "-1"
                             ? kInvalidPoint3DId
                             : reader.Unsigned<std::uint64_t>(
                                   id, field(at + " POINT3D_ID (or -1)"));
    }
  }
  model.images = std::move(images);
  model.BuildIndex();
}

void ReadPoints3DText(ColmapModel& model, std::istream& stream,
                      const std::string& source) {
  static constexpr const char* kFields[] = {"X", "Y", "Z"};
  static constexpr const char* kColors[] = {"R", "G", "B"};
  LineReader reader(stream, source);
  std::vector<ColmapPoint3D> points;
  std::vector<std::string_view> tokens;
  std::string_view line;
  while (reader.NextRecord(line)) {
    ColmapPoint3D& point = points.emplace_back();
    const auto field = [&](std::string name) {
      return [&point, name] {
        return "point3D " + Id(point.point3D_id) + " " + name;
      };
    };
    Split(line, tokens);
    if (tokens.size() < 8) {
      reader.Fail([] { return std::string("line"); },
                  Id(tokens.size()) + " values",
                  "expected POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[]");
    }
    point.point3D_id = reader.Unsigned<std::uint64_t>(
        tokens[0], [] { return std::string("POINT3D_ID"); });
    for (int k = 0; k < 3; ++k) {
      point.xyz(k) = reader.Real(tokens[1 + k], field(kFields[k]));
    }
    for (int k = 0; k < 3; ++k) {
      point.rgb[k] =
          reader.Unsigned<std::uint8_t>(tokens[4 + k], field(kColors[k]));
    }
    point.error = reader.Real(tokens[7], field("ERROR"));
    if ((tokens.size() - 8) % 2 != 0) {
      reader.Fail(field("TRACK"), Id(tokens.size() - 8) + " values",
                  "expected pairs IMAGE_ID, POINT2D_IDX");
    }
    point.track.resize((tokens.size() - 8) / 2);
    for (std::size_t k = 0; k < point.track.size(); ++k) {
      const std::string at = "track element " + Id(k);
      point.track[k].image_id = reader.Unsigned<std::uint32_t>(
          tokens[8 + 2 * k], field(at + " IMAGE_ID"));
      point.track[k].point2D_idx = reader.Unsigned<std::uint32_t>(
          tokens[9 + 2 * k], field(at + " POINT2D_IDX"));
    }
  }
  model.points3D = std::move(points);
  model.BuildIndex();
}

void ReadCamerasText(ColmapModel& model, const std::filesystem::path& path) {
  ReadModelFile(path, [&](std::istream& stream, const std::string& source) {
    ReadCamerasText(model, stream, source);
  });
}

void ReadImagesText(ColmapModel& model, const std::filesystem::path& path) {
  ReadModelFile(path, [&](std::istream& stream, const std::string& source) {
    ReadImagesText(model, stream, source);
  });
}

void ReadPoints3DText(ColmapModel& model, const std::filesystem::path& path) {
  ReadModelFile(path, [&](std::istream& stream, const std::string& source) {
    ReadPoints3DText(model, stream, source);
  });
}

void WriteCamerasText(const ColmapModel& model, std::ostream& stream) {
  std::string line = "# Camera list with one line of data per camera:\n";
  line += "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  line += "# Number of cameras: ";
  AppendInt(line, model.cameras.size());
  stream << line << '\n';
  for (const ColmapCamera& camera : model.cameras) {
    const CameraModelInfo& info = CheckedCameraModel(camera, "cameras.txt");
    line.clear();
    AppendInt(line, camera.camera_id);
    line += ' ';
    line += info.name;
    line += ' ';
    AppendInt(line, camera.width);
    line += ' ';
    AppendInt(line, camera.height);
    for (const double param : camera.params) {
      line += ' ';
      AppendReal(line, param);
    }
    stream << line << '\n';
  }
  CheckWritten(stream, "cameras.txt");
}

void WriteImagesText(const ColmapModel& model, std::ostream& stream) {
  std::string line = "# Image list with two lines of data per image:\n";
  line += "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n";
  line += "#   POINTS2D[] as (X, Y, POINT3D_ID)\n";
  line += "# Number of images: ";
  AppendInt(line, model.images.size());
  line += ", mean observations per image: ";
  AppendReal(line, model.MeanObservationsPerImage());
  stream << line << '\n';
  for (const ColmapImage& image : model.images) {
    if (image.name.find('\n') != std::string::npos ||
        Trim(image.name).size() != image.name.size()) {
      throw Error("images.txt", "image " + Id(image.image_id) + " name",
                  Quoted(image.name),
                  "a name with a line break or with blanks at either end "
                  "cannot be read back from images.txt");
    }
    line.clear();
    AppendInt(line, image.image_id);
    for (int k = 0; k < 4; ++k) {
      line += ' ';
      AppendReal(line, image.qvec(k));
    }
    for (int k = 0; k < 3; ++k) {
      line += ' ';
      AppendReal(line, image.tvec(k));
    }
    line += ' ';
    AppendInt(line, image.camera_id);
    line += ' ';  // COLMAP writes it even before an empty name
    line += image.name;
    line += '\n';
    for (std::size_t j = 0; j < image.points2D.size(); ++j) {
      const ColmapPoint2D& point = image.points2D[j];
      if (j > 0) line += ' ';
      AppendReal(line, point.xy.x());
      line += ' ';
      AppendReal(line, point.xy.y());
      line += ' ';
      if (point.HasPoint3D()) {
        AppendInt(line, point.point3D_id);
      } else {
        line += "-1";
      }
    }
    stream << line << '\n';
  }
  CheckWritten(stream, "images.txt");
}

void WritePoints3DText(const ColmapModel& model, std::ostream& stream) {
  std::string line = "# 3D point list with one line of data per point:\n";
  line += "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as ";
  line += "(IMAGE_ID, POINT2D_IDX)\n";
  line += "# Number of points: ";
  AppendInt(line, model.points3D.size());
  line += ", mean track length: ";
  AppendReal(line, model.MeanTrackLength());
  stream << line << '\n';
  for (const ColmapPoint3D& point : model.points3D) {
    line.clear();
    AppendInt(line, point.point3D_id);
    for (int k = 0; k < 3; ++k) {
      line += ' ';
      AppendReal(line, point.xyz(k));
    }
    for (const std::uint8_t c : point.rgb) {
      line += ' ';
      AppendInt(line, c);
    }
    line += ' ';
    AppendReal(line, point.error);
    line += ' ';  // COLMAP writes it even before an empty track
    for (std::size_t k = 0; k < point.track.size(); ++k) {
      if (k > 0) line += ' ';
      AppendInt(line, point.track[k].image_id);
      line += ' ';
      AppendInt(line, point.track[k].point2D_idx);
    }
    stream << line << '\n';
  }
  CheckWritten(stream, "points3D.txt");
}

void WriteCamerasText(const ColmapModel& model,
                      const std::filesystem::path& path) {
  WriteModelFile(
      path, [&](std::ostream& stream) { WriteCamerasText(model, stream); });
}

void WriteImagesText(const ColmapModel& model,
                     const std::filesystem::path& path) {
  WriteModelFile(path,
                 [&](std::ostream& stream) { WriteImagesText(model, stream); });
}

void WritePoints3DText(const ColmapModel& model,
                       const std::filesystem::path& path) {
  WriteModelFile(
      path, [&](std::ostream& stream) { WritePoints3DText(model, stream); });
}

}  // namespace pano4d
