#include "colmap_ext/model_io_binary.h"

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <new>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "colmap_ext/model.h"
#include "colmap_ext/model_io_text.h"
#include "src/core/error.h"
#include "src/core/log.h"
#include "tests/support/test_files.h"

// The largest single allocation since the last reset, to show that corrupt
// counts are refused before memory is reserved for them.
namespace {
std::atomic<std::size_t> largest_allocation{0};
}  // namespace

void* operator new(std::size_t size) {
  std::size_t seen = largest_allocation.load(std::memory_order_relaxed);
  while (size > seen && !largest_allocation.compare_exchange_weak(seen, size)) {
  }
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
// GCC cannot see that operator new above is replaced too, and would warn
// about free() on memory from new.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
#endif
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

namespace pano4d {
namespace {

// A model that exercises the format: all 11 camera models with parameters
// of every magnitude and sign, scattered ids, images without observations,
// points2D without 3D points, and tracks from 1 to 25 elements.
ColmapModel BuildModel() {
  std::mt19937 rng(11);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> pixel(0.0, 2000.0);
  ColmapModel model;
  for (int m = 0; m < 11; ++m) {
    ColmapCamera& camera = model.cameras.emplace_back();
    camera.camera_id = 100 + 7 * m;
    camera.model_id = m;
    camera.width = 640 + m;
    camera.height = 480 + 3 * m;
    camera.params.resize(GetCameraModelInfo(CameraModelId(m)).num_params);
    for (double& p : camera.params) p = normal(rng) * std::pow(10.0, m - 5);
    // Focal lengths and principal point as a real camera has them, so that
    // every camera also passes pano4d's Camera::Check().
    const bool single = GetCameraModelInfo(CameraModelId(m)).single_focal;
    for (int k = 0; k < (single ? 3 : 4); ++k) {
      camera.params[k] = 300.0 + 100.0 * std::abs(normal(rng));
    }
  }
  model.cameras[3].params[1] = -0.0;
  for (int i = 0; i < 30; ++i) {
    ColmapImage& image = model.images.emplace_back();
    image.image_id = 5 * i + 2;
    image.qvec =
        Eigen::Vector4d(normal(rng), normal(rng), normal(rng), normal(rng));
    if (i % 2 == 0) image.qvec.normalize();  // odd ones as a user might store
    image.tvec = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)) * 10;
    image.camera_id = model.cameras[i % 11].camera_id;
    image.name = "frames/" + std::to_string(i) + ".png";
  }
  std::uniform_int_distribution<int> coin(0, 3);
  for (int k = 0; k < 120; ++k) {
    ColmapPoint3D& point = model.points3D.emplace_back();
    point.point3D_id = 1000 + 13 * k;
    point.xyz = Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    point.rgb = {static_cast<std::uint8_t>(k), 255, 0};
    point.error = std::abs(normal(rng));
    const int length = k % 10 == 0 ? 25 : 1 + k % 4;
    for (int e = 0; e < length; ++e) {
      // Every third image has no observations.
      const int i = (k + 3 * e + 1) % 30;
      ColmapImage& image = model.images[i % 3 == 0 ? (i + 1) % 30 : i];
      if (coin(rng) == 0) image.points2D.push_back({{pixel(rng), 0.5}});
      image.points2D.push_back({{pixel(rng), pixel(rng)}, point.point3D_id});
      point.track.push_back({image.image_id, static_cast<std::uint32_t>(
                                                 image.points2D.size() - 1)});
    }
  }
  model.images[1].points2D.push_back({{1.5, 2.5}});  // trailing, no 3D point
  model.BuildIndex();
  return model;
}

struct Files {
  std::string cameras, images, points3D;
};

Files WriteBinary(const ColmapModel& model) {
  std::ostringstream cameras, images, points3D;
  WriteCamerasBinary(model, cameras);
  WriteImagesBinary(model, images);
  WritePoints3DBinary(model, points3D);
  return {cameras.str(), images.str(), points3D.str()};
}

ColmapModel ReadBinary(const Files& files) {
  ColmapModel model;
  std::istringstream cameras(files.cameras), images(files.images),
      points3D(files.points3D);
  ReadCamerasBinary(model, cameras);
  ReadImagesBinary(model, images);
  ReadPoints3DBinary(model, points3D);
  return model;
}

// What the error says, or "" when reading succeeds.
template <typename Read>
std::string ErrorOf(const std::string& bytes, const Read& read,
                    const std::string& source) {
  ColmapModel model;
  std::istringstream stream(bytes);
  try {
    read(model, stream, source);
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

void ReadCameras(ColmapModel& m, std::istream& s, const std::string& src) {
  ReadCamerasBinary(m, s, src);
}
void ReadImages(ColmapModel& m, std::istream& s, const std::string& src) {
  ReadImagesBinary(m, s, src);
}
void ReadPoints(ColmapModel& m, std::istream& s, const std::string& src) {
  ReadPoints3DBinary(m, s, src);
}

std::string WithCount(std::string bytes, std::size_t at, std::uint64_t count) {
  std::memcpy(bytes.data() + at, &count, sizeof(count));
  return bytes;
}

TEST(ModelIoBinaryTest, TheBuiltModelIsConsistent) {
  const ColmapModel model = BuildModel();
  EXPECT_NO_THROW(model.Check());
  std::size_t track_elements = 0;
  for (const ColmapPoint3D& p : model.points3D)
    track_elements += p.track.size();
  EXPECT_EQ(model.NumObservations(), track_elements);
  EXPECT_EQ(model.points3D[0].track.size(), 25u);
  EXPECT_TRUE(model.images[0].points2D.empty());
}

TEST(ModelIoBinaryTest, WriteReadWriteGivesTheSameBytes) {
  const Files files = WriteBinary(BuildModel());
  const ColmapModel read = ReadBinary(files);
  const Files again = WriteBinary(read);
  EXPECT_EQ(again.cameras, files.cameras);
  EXPECT_EQ(again.images, files.images);
  EXPECT_EQ(again.points3D, files.points3D);
  EXPECT_NO_THROW(read.Check());
  ASSERT_EQ(read.images.size(), 30u);
  EXPECT_EQ(read.images[4].qvec, BuildModel().images[4].qvec);
  EXPECT_EQ(read.images[1].points2D.back().point3D_id, kInvalidPoint3DId);
}

TEST(ModelIoBinaryTest, BinaryToTextToBinaryGivesTheSameBytes) {
  const Files files = WriteBinary(BuildModel());
  const ColmapModel read = ReadBinary(files);
  std::ostringstream cameras, images, points3D;
  WriteCamerasText(read, cameras);
  WriteImagesText(read, images);
  WritePoints3DText(read, points3D);
  ColmapModel text;
  std::istringstream cameras_in(cameras.str()), images_in(images.str()),
      points_in(points3D.str());
  ReadCamerasText(text, cameras_in);
  ReadImagesText(text, images_in);
  ReadPoints3DText(text, points_in);
  const Files again = WriteBinary(text);
  EXPECT_EQ(again.cameras, files.cameras);
  EXPECT_EQ(again.images, files.images);
  EXPECT_EQ(again.points3D, files.points3D);
}

TEST(ModelIoBinaryTest, TruncationAtEveryByteNamesTheFileAndOffset) {
  const Files files = WriteBinary(BuildModel());
  const std::pair<const std::string*, decltype(&ReadCameras)> cases[] = {
      {&files.cameras, &ReadCameras},
      {&files.images, &ReadImages},
      {&files.points3D, &ReadPoints}};
  for (const auto& [bytes, read] : cases) {
    for (std::size_t size = 0; size < bytes->size(); ++size) {
      const std::string message =
          ErrorOf(bytes->substr(0, size), read, "sparse/0/model.bin");
      ASSERT_NE(message.find("sparse/0/model.bin: field '"), std::string::npos)
          << "cut at " << size << ": " << message;
      ASSERT_NE(message.find("of " + std::to_string(size)), std::string::npos)
          << "cut at " << size << ": " << message;
    }
  }
  // Two cases in full, as a reader of the log sees them. Counts are checked
  // against the bytes left first, so most cuts are caught there.
  const std::size_t size = files.images.size();
  EXPECT_EQ(
      ErrorOf(files.images.substr(0, size - 5), &ReadImages, "images.bin"),
      "images.bin: field 'image 147 num_points2D' = 27: count at byte 18890 "
      "needs at least 648 more bytes, but only 643 remain of 19541");
  ColmapModel one;
  one.cameras.push_back({3, 1, 640, 480, {500, 500, 320, 240}});
  const std::string camera = WriteBinary(one).cameras;
  EXPECT_EQ(ErrorOf(camera.substr(0, camera.size() - 5), &ReadCameras,
                    "sparse/0/cameras.bin"),
            "sparse/0/cameras.bin: field 'camera 3 params' = byte 56: "
            "truncated at byte 64 of 59: the field needs 8 bytes");
}

TEST(ModelIoBinaryTest, AHugeCountFailsBeforeAllocating) {
  const Files files = WriteBinary(BuildModel());
  const std::uint64_t huge = std::uint64_t{1} << 60;
  largest_allocation = 0;
  ReadBinary(files);  // the hook sees the reader's allocations
  EXPECT_GT(largest_allocation.load(), std::size_t{10000});
  largest_allocation = 0;
  EXPECT_NE(ErrorOf(WithCount(files.cameras, 0, huge), &ReadCameras, "c.bin")
                .find("field 'num_cameras' = 1152921504606846976: count at "
                      "byte 0 needs at least"),
            std::string::npos);
  EXPECT_NE(ErrorOf(WithCount(files.images, 0, ~std::uint64_t{0}), &ReadImages,
                    "i.bin")
                .find("num_images"),
            std::string::npos);
  EXPECT_NE(ErrorOf(WithCount(files.points3D, 0, huge), &ReadPoints, "p.bin")
                .find("num_points3D"),
            std::string::npos);
  // The points2D count of the first image and the track length of the first
  // point sit after their fixed-size fields.
  const std::size_t name_end = files.images.find('\0', 8 + 4 + 56 + 4);
  EXPECT_NE(
      ErrorOf(WithCount(files.images, name_end + 1, huge), &ReadImages, "i.bin")
          .find("field 'image 2 num_points2D'"),
      std::string::npos);
  EXPECT_NE(ErrorOf(WithCount(files.points3D, 8 + 8 + 24 + 3 + 8, huge),
                    &ReadPoints, "p.bin")
                .find("field 'point3D 1000 track_length'"),
            std::string::npos);
  EXPECT_LT(largest_allocation.load(), std::size_t{1} << 20);
}

TEST(ModelIoBinaryTest, RefusesTrailingBytesAndUnknownModels) {
  const Files files = WriteBinary(BuildModel());
  EXPECT_NE(ErrorOf(files.points3D + "x", &ReadPoints, "p.bin")
                .find("1 unexpected bytes after the last point3D"),
            std::string::npos);
  std::string cameras = files.cameras;
  const std::int32_t model_id = 11;  // not in COLMAP 3.8
  std::memcpy(cameras.data() + 8 + 4, &model_id, 4);
  EXPECT_EQ(ErrorOf(cameras, &ReadCameras, "cameras.bin"),
            "cameras.bin: field 'camera 100 model_id' = 11: at byte 12: not a "
            "COLMAP 3.8 camera model id (0 to 10)");

  ColmapModel model = BuildModel();
  model.cameras[2].params.pop_back();
  std::ostringstream out;
  EXPECT_THROW(WriteCamerasBinary(model, out), Error);
  model = BuildModel();
  model.images[3].name += '\0';
  EXPECT_THROW(WriteImagesBinary(model, out), Error);
}

// A stream that cannot seek, like a pipe.
class PipeBuffer : public std::streambuf {
 public:
  explicit PipeBuffer(std::string data) : data_(std::move(data)) {
    setg(data_.data(), data_.data(), data_.data() + data_.size());
  }

 private:
  std::string data_;
};

TEST(ModelIoBinaryTest, ReadsStreamsThatCannotSeek) {
  const Files files = WriteBinary(BuildModel());
  PipeBuffer buffer(files.images);
  std::istream pipe(&buffer);
  ColmapModel model;
  ReadImagesBinary(model, pipe);
  EXPECT_EQ(model.images.size(), 30u);
  PipeBuffer cut(files.images.substr(0, 100));
  std::istream cut_pipe(&cut);
  EXPECT_THROW(ReadImagesBinary(model, cut_pipe), Error);
}

TEST(ModelIoBinaryTest, FolderWithRigsAndFramesStillReads) {
  testing::TempDir dir;
  const ColmapModel model = BuildModel();
  WriteModel(model, dir.path(), ColmapFormat::kBinary);
  testing::WriteText(dir / "rigs.bin", "\x01\x02");
  testing::WriteText(dir / "frames.bin", "\x03");
  std::ostringstream log;
  SetLogSink(&log);
  const ColmapModel read = ReadModel(dir.path());
  SetLogSink(nullptr);
  EXPECT_EQ(read.images.size(), model.images.size());
  EXPECT_NE(log.str().find("ignored rigs.bin, frames.bin"), std::string::npos)
      << log.str();
  EXPECT_EQ(DetectModelFormat(dir.path()), ColmapFormat::kBinary);
}

TEST(ModelIoBinaryTest, FolderFormatDetection) {
  testing::TempDir dir;
  const ColmapModel model = BuildModel();
  EXPECT_THROW(ReadModel(dir.path()), Error);
  WriteModel(model, dir.path(), ColmapFormat::kText);
  EXPECT_EQ(DetectModelFormat(dir.path()), ColmapFormat::kText);
  EXPECT_EQ(ReadModel(dir.path()).points3D.size(), model.points3D.size());
  // An incomplete binary set does not shadow the text one.
  WriteCamerasBinary(model, dir / "cameras.bin");
  EXPECT_EQ(DetectModelFormat(dir.path()), ColmapFormat::kText);
  WriteModel(model, dir.path(), ColmapFormat::kBinary);
  EXPECT_EQ(DetectModelFormat(dir.path()), ColmapFormat::kBinary);
  try {
    ColmapModel m;
    ReadImagesBinary(m, dir / "missing.bin");
    ADD_FAILURE();
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("missing.bin"), std::string::npos);
  }
}

std::string CheckError(const ColmapModel& model) {
  try {
    model.Check("m");
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

TEST(ModelCheckTest, NamesTheDanglingReference) {
  ColmapModel model = BuildModel();
  model.images[5].camera_id = 9;
  EXPECT_EQ(CheckError(model),
            "m: field 'image 27 camera_id' = 9: no camera has this id");

  model = BuildModel();
  model.points3D.erase(model.points3D.begin() + 7);  // point 1091
  EXPECT_NE(CheckError(model).find("= 1091: no 3D point has this id"),
            std::string::npos);

  model = BuildModel();
  model.points3D[2].track[0].image_id = 3;
  EXPECT_EQ(CheckError(model),
            "m: field 'point3D 1026 track element 0 image_id' = 3: no image "
            "has this id");

  model = BuildModel();
  model.points3D[2].track[0].point2D_idx = 999;
  EXPECT_NE(CheckError(model).find("point2D_idx' = 999"), std::string::npos);

  model = BuildModel();
  std::swap(model.points3D[1].track[0], model.points3D[2].track[0]);
  EXPECT_NE(CheckError(model).find("refers to point3D 1026, not to this"),
            std::string::npos);

  model = BuildModel();
  model.points3D[3].track.push_back(model.points3D[3].track[0]);
  EXPECT_NE(CheckError(model).find("is listed twice"), std::string::npos);

  model = BuildModel();
  model.points3D[3].track.pop_back();
  EXPECT_NE(CheckError(model).find("track of that point does not list"),
            std::string::npos);

  model = BuildModel();
  model.cameras.push_back(model.cameras[0]);
  EXPECT_EQ(CheckError(model),
            "m: field 'camera 100': camera id appears more than once");

  model = BuildModel();
  model.cameras[4].model_id = 42;
  EXPECT_NE(CheckError(model).find("camera 128 model_id' = 42"),
            std::string::npos);
}

TEST(ModelTest, CountsAndLookups) {
  ColmapModel model = BuildModel();
  const ColmapModelStats stats = model.Stats();
  EXPECT_EQ(stats.cameras, 11u);
  EXPECT_EQ(stats.registered_images, 30u);
  EXPECT_EQ(stats.points3D, 120u);
  EXPECT_DOUBLE_EQ(stats.mean_track_length,
                   double(stats.observations) / stats.points3D);
  EXPECT_DOUBLE_EQ(stats.mean_observations_per_image,
                   double(stats.observations) / 30);
  EXPECT_EQ(model.FindImage(7)->name, "frames/1.png");
  EXPECT_EQ(model.FindImageByName("frames/2.png")->image_id, 12u);
  EXPECT_EQ(model.FindCamera(1), nullptr);
  EXPECT_EQ(model.FindPoint3D(1013)->point3D_id, 1013u);
  // Edits without BuildIndex() are still found.
  model.images.insert(model.images.begin(), ColmapImage{});
  model.images[0].image_id = 7;
  EXPECT_EQ(model.FindImage(7), &model.images[0]);
  ColmapPoint3D point;
  point.point3D_id = 5;
  model.points3D.push_back(point);
  EXPECT_EQ(model.FindPoint3D(5), &model.points3D.back());
}

TEST(ModelTest, PosesAndCameras) {
  const ColmapModel model = BuildModel();
  const ColmapImage& image = model.images[3];  // qvec not unit
  const Rigid3d pose = image.CamFromWorld();
  EXPECT_LT((pose * image.Center()).norm(), 1e-9);
  const Eigen::Vector4d q = image.qvec.normalized();
  EXPECT_LT((pose.ColmapQvec() - q).norm(), 1e-15);

  ColmapImage moved = image;
  moved.SetCamFromWorld(pose);
  EXPECT_LT((moved.qvec - q).norm(), 1e-15);

  const PosedCamera posed = model.PosedCameraOf(model.images[2]);
  EXPECT_EQ(static_cast<int>(posed.camera.model_id), 2);
  EXPECT_EQ(posed.camera.width, 642);
  ColmapCamera back =
      FromCamera(model.cameras[0].camera_id, ToCamera(model.cameras[0]));
  EXPECT_EQ(back.params, model.cameras[0].params);
  EXPECT_EQ(back.width, model.cameras[0].width);

  ColmapImage bad = image;
  bad.qvec.setZero();
  EXPECT_THROW(bad.Center(), Error);
  ColmapCamera huge = model.cameras[0];
  huge.width = std::uint64_t{1} << 40;
  EXPECT_THROW(ToCamera(huge), Error);
}

}  // namespace
}  // namespace pano4d
