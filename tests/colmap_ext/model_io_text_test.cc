#include "colmap_ext/model_io_text.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "colmap_ext/model.h"
#include "colmap_ext/model_io_binary.h"
#include "src/core/error.h"
#include "src/core/log.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

// Written by `colmap model_converter --output_type TXT` (COLMAP 3.8) from
// binary models made for this test: all 11 camera models; edge values
// (-0, -inf, NaN, 1e300, the smallest denormal, an empty name, an empty
// track); and a model whose image refers to a missing 3D point, with a
// name that holds a space and a qvec COLMAP normalized.
constexpr char kColmapCameras[] =
    R"txt(# Camera list with one line of data per camera:
#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]
# Number of cameras: 11
11 THIN_PRISM_FISHEYE 650 490 0.00060913896902807085 0.00010151253021450147 722.0177217066497 0.059419512527099254 -9.3508173761151992e-05 -8.3353172439220424e-06 -0.0094002425453663333 -5.0088154869315443e-05 0.00059457542933228735 -3.1115427180701019e-05 -0.06650593853052629 5.4760798096025632e-05
10 RADIAL_FISHEYE 649 489 8.8202702261090966 -0.030149775544531687 -1.711509623217893e-06 0.076957591475688591 -8.370639980055117e-07
9 SIMPLE_RADIAL_FISHEYE 648 488 0.0055479436459180496 -1.4781864062369966e-06 -0.03779636517151963 0.001399986677527605
8 FOV 647 487 -0.31234821748037067 -0.0081736536178663288 3.18429627239649e-06 -232.62073421992025 618.27980174495906
7 FULL_OPENCV 646 486 -0.26575233714582391 -827.0648205435034 -0.0007841374758118003 0.41876835226290376 -2.5895466670850653e-06 -0.0061359717793952225 4.06764177207672 0.00029431233063860528 4.4771168669661692e-08 541.04627966160115 840.17286986544377 -535.64774387397085
6 OPENCV_FISHEYE 645 485 791.1507892829834 8.7288117359891935 0.00015434501022632219 -39.326297813416474 692.39483685662549 -2.1329275386032087e-06 -0.3954605396479427 -0.00017137200139845143
5 OPENCV 644 484 878.33403789717318 -0.0053383109948485479 35.369707969994877 9.0448891058238753e-06 -167.64012221130776 8.4437712493977491e-05 -0.062818746821056468 -0.75822008038838717
4 RADIAL 643 483 -955.3557779573523 -9.8159012289123009 3.7296770835815951 451.70520289303039 -55.661666745392992
3 SIMPLE_RADIAL 642 482 0.0391665733536887 0.0044308006468156517 1.8230687000260784e-05 8.0285491522296729e-06
2 PINHOLE 641 481 0.003031859454455259 -8.1228082645153025e-06 7.8663408511527022 -1.3446586418989328e-06
1 SIMPLE_PINHOLE 640 480 -7.3127151177519755e-05 -48.986194852115659 52.192488982515115
)txt";
constexpr char kColmapImages[] =
    R"txt(# Image list with two lines of data per image:
#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME
#   POINTS2D[] as (X, Y, POINT3D_ID)
# Number of images: 5, mean observations per image: 3.2000000000000002
5 -0.18051936177794936 -0.0046597608091931446 -0.74939472974360666 -0.63702322224938523 -0.03023808818079475 0.90919718035856056 0.55259672370715351 5 img_4.png
180.06509789511193 75.343341353606007 11 548.82351554746958 389.3467497362484 -1 360.53794280386148 64.868707677467953 12 274.71386534228225 127.93701651497506 -1 61.699265659814202 182.03218078203489 13 350.48097297596837 438.9334269132371 -1 536.1233600955494 256.47842103659644 14 491.48875706438167 255.60979927053606 -1 41.80657255871381 19.392217700529919 15 85.130887840719893 79.945224205211801 -1 344.45359331592647 128.64477309864583 16 212.62942600349817 242.8264719526727 -1
4 0.15448977366915287 0.6574878296368516 -0.37679873279451331 0.63392852804990996 1.0814736075431157 0.91976864584094342 -0.3779110733700537 4 img_3.png
83.450322191621069 269.14431409377295 6 544.3370630164934 283.48030621795931 -1 139.25781708813247 432.39023770194257 7 294.94559369810622 397.39831519525427 -1 556.72731387031183 374.40828932770421 8 398.69620088993906 17.963220040686725 -1 128.26077149835049 47.532174131018209 9 366.96492993427751 430.35155808788579 -1 378.50195977267566 236.32836021575048 10
3 -0.5015875909741383 0.17820626503582745 -0.75826382945254922 0.3764151705586487 0.073484196471913843 0.30299307068040249 0.36007812192915628 3 img_2.png
625.26473987385987 302.77048157862731 3 444.83257063197857 216.4056130285112 -1 335.29308151486595 14.736132841937533 4 431.93764961169222 385.62504644839453 -1 422.28729072069098 204.62370178265016 5 471.96880006125423 60.327994708669067 -1
2 0.7387404637608348 0.19272484127263906 -0.64512178341500936 -0.03061939454497533 1.6181958922262445 2.4740034504454615 0.55832923868590423 2 img_1.png
625.11249641938673 463.47048856847994 1 276.25955017585591 468.26564677054205 -1 144.23936852390534 190.71137719081071 2
1 1 0 0 0 -0.492330548542114 0.010848294004179542 -0.34834505068818433 1 img_0.png

)txt";
constexpr char kColmapPoints3D[] =
    R"txt(# 3D point list with one line of data per point:
#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)
# Number of points: 16, mean track length: 1
16 -1.1845636314400183 1.4234292549541669 1.4158793909482816 46 46 46 0.65201053451267055 5 10
15 -0.15719758016896981 -0.071266200410088326 1.2469792415914192 157 157 157 0.19921589826331432 5 8
14 0.30091206848541113 1.3539240834956061 1.2413914988111874 240 240 240 0.66183442887534927 5 6
1 0.48051146421030966 1.6324269885263578 -0.59938196402978594 250 250 250 0.13534597739545295 2 0
2 -0.44525341274103519 -0.14830057157175158 0.37816878023920492 75 75 75 0.82850597146911353 2 2
3 0.09491651402747682 -0.74709368599056691 1.1626872108201345 193 193 193 0.076651637038450793 3 0
4 -1.2280751280342974 -0.40137099752781696 0.91027781864376056 151 151 151 0.5644468332401974 3 2
5 -0.28162760358909383 0.98602417205414239 -0.50188009100274045 141 141 141 0.10773068507771688 3 4
6 0.80302071749031656 0.2374178064731583 -0.12935705420114438 211 211 211 0.1151024984279273 4 0
7 -0.11214625907847199 0.21446800920290465 -0.18893516839915861 122 122 122 0.78551213434456657 4 2
8 -0.50833542905134887 -0.30841009632734145 -1.4401041550715237 81 81 81 0.74400641653700839 4 4
9 0.45884538997622731 1.7552494870866626 1.3236502859608845 193 193 193 0.80648736633557105 4 6
10 -1.7802125065446883 -0.49212972744087968 -1.4991627747388032 161 161 161 0.10012914395045203 4 8
11 -0.48928584311325746 -0.16415754519868211 -0.23217498531687308 5 5 5 0.78685995178359458 5 0
12 1.4374734012883041 -0.72557463996254268 -0.42565753505923781 204 204 204 0.062964790047645325 5 2
13 0.90087372572657531 2.2637004905785969 -1.3698051877149384 233 233 233 0.11136231012689191 5 4
)txt";
constexpr char kEdgeCameras[] =
    R"txt(# Camera list with one line of data per camera:
#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]
# Number of cameras: 1
1 SIMPLE_PINHOLE 10 10 5 -0 -inf
)txt";
constexpr char kEdgeImages[] =
    R"txt(# Image list with two lines of data per image:
#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME
#   POINTS2D[] as (X, Y, POINT3D_ID)
# Number of images: 1, mean observations per image: 0
1 1 0 0 0 1.0000000000000001e+300 1e-300 4.9406564584124654e-324 1 

)txt";
constexpr char kEdgePoints3D[] =
    R"txt(# 3D point list with one line of data per point:
#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)
# Number of points: 1, mean track length: 0
5 1 2 3 1 2 3 -nan 
)txt";
constexpr char kInconsistentImages[] =
    R"txt(# Image list with two lines of data per image:
#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME
#   POINTS2D[] as (X, Y, POINT3D_ID)
# Number of images: 2, mean observations per image: 0.5
7 0.18257418583505539 0.36514837167011077 0.54772255750516619 0.73029674334022154 0 0 0 1 c

1 0.59999999999999998 0.80000000000000004 0 0 0 0 0 1 a b
1 2 999 1 2 -1
)txt";
constexpr char kInconsistentPoints3D[] =
    R"txt(# 3D point list with one line of data per point:
#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)
# Number of points: 1, mean track length: 1
5 1 2 3 1 2 3 nan 1 0 1 1 9 9
)txt";

// A model that exercises the format: all 11 camera models with parameters
// of every magnitude and sign, scattered ids, images without observations,
// points2D without 3D points, and tracks from 1 to 25 elements.
ColmapModel BuildModel() {
  std::mt19937 rng(17);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> pixel(0.0, 2000.0);
  ColmapModel model;
  for (int m = 0; m < 11; ++m) {
    ColmapCamera& camera = model.cameras.emplace_back();
    camera.camera_id = 1 + 3 * m;
    camera.model_id = m;
    camera.width = 1920;
    camera.height = 1080 + m;
    camera.params.resize(GetCameraModelInfo(CameraModelId(m)).num_params);
    for (double& p : camera.params)
      p = normal(rng) * std::pow(10.0, 2 * m - 10);
  }
  for (int i = 0; i < 20; ++i) {
    ColmapImage& image = model.images.emplace_back();
    image.image_id = 20 - i;
    image.qvec =
        Eigen::Vector4d(normal(rng), normal(rng), normal(rng), normal(rng));
    image.tvec = Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    image.camera_id = model.cameras[(i * 5) % 11].camera_id;
    image.name = i == 4 ? "with two spaces.jpg" : "img" + std::to_string(i);
  }
  for (int k = 0; k < 60; ++k) {
    ColmapPoint3D& point = model.points3D.emplace_back();
    point.point3D_id = 7 + 1000 * k;
    point.xyz = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)) * 1e3;
    point.rgb = {0, static_cast<std::uint8_t>(4 * k), 255};
    point.error = std::abs(normal(rng));
    const int length = k % 7 == 0 ? 19 : 2;
    for (int e = 0; e < length; ++e) {
      const int i = (k + e) % 20;
      ColmapImage& image = model.images[i % 5 == 0 ? i + 1 : i];
      image.points2D.push_back({{pixel(rng), -1.0}});
      image.points2D.push_back({{pixel(rng), pixel(rng)}, point.point3D_id});
      point.track.push_back({image.image_id, static_cast<std::uint32_t>(
                                                 image.points2D.size() - 1)});
    }
  }
  model.BuildIndex();
  return model;
}

struct Files {
  std::string cameras, images, points3D;
};

Files WriteText(const ColmapModel& model) {
  std::ostringstream cameras, images, points3D;
  WriteCamerasText(model, cameras);
  WriteImagesText(model, images);
  WritePoints3DText(model, points3D);
  return {cameras.str(), images.str(), points3D.str()};
}

ColmapModel ReadText(const Files& files) {
  ColmapModel model;
  std::istringstream cameras(files.cameras), images(files.images),
      points3D(files.points3D);
  ReadCamerasText(model, cameras);
  ReadImagesText(model, images);
  ReadPoints3DText(model, points3D);
  return model;
}

std::string BinaryOf(const ColmapModel& model) {
  std::ostringstream out;
  WriteCamerasBinary(model, out);
  WriteImagesBinary(model, out);
  WritePoints3DBinary(model, out);
  return out.str();
}

template <typename Read>
std::string ErrorOf(const std::string& text, const Read& read) {
  ColmapModel model;
  std::istringstream stream(text);
  try {
    read(model, stream);
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

const auto kReadCameras = [](ColmapModel& m, std::istream& s) {
  ReadCamerasText(m, s);
};
const auto kReadImages = [](ColmapModel& m, std::istream& s) {
  ReadImagesText(m, s);
};
const auto kReadPoints = [](ColmapModel& m, std::istream& s) {
  ReadPoints3DText(m, s);
};

TEST(ModelIoTextTest, WriteReadWriteGivesTheSameBytes) {
  const ColmapModel model = BuildModel();
  ASSERT_NO_THROW(model.Check());
  const Files files = WriteText(model);
  const ColmapModel read = ReadText(files);
  const Files again = WriteText(read);
  EXPECT_EQ(again.cameras, files.cameras);
  EXPECT_EQ(again.images, files.images);
  EXPECT_EQ(again.points3D, files.points3D);
  // Text loses nothing: the binary form of both models is the same.
  EXPECT_EQ(BinaryOf(read), BinaryOf(model));
  EXPECT_EQ(read.FindImage(16)->name, "with two spaces.jpg");
}

TEST(ModelIoTextTest, RewritesColmapsOwnOutputExactly) {
  const Files cases[] = {
      {kColmapCameras, kColmapImages, kColmapPoints3D},
      {kEdgeCameras, kEdgeImages, kEdgePoints3D},
      {kEdgeCameras, kInconsistentImages, kInconsistentPoints3D}};
  for (const Files& files : cases) {
    const Files again = WriteText(ReadText(files));
    EXPECT_EQ(again.cameras, files.cameras);
    EXPECT_EQ(again.images, files.images);
    EXPECT_EQ(again.points3D, files.points3D);
  }
}

TEST(ModelIoTextTest, WritesColmapsHeadersAndNumbers) {
  // The edge model built by hand gives COLMAP's bytes.
  ColmapModel model;
  model.cameras.push_back({1, 0, 10, 10, {5, -0.0, -INFINITY}});
  ColmapImage& image = model.images.emplace_back();
  image.image_id = 1;
  image.tvec = {1e300, 1e-300, 4.9406564584124654e-324};
  image.camera_id = 1;
  model.points3D.push_back(
      {5, {1, 2, 3}, {1, 2, 3}, -std::numeric_limits<double>::quiet_NaN(), {}});
  const Files files = WriteText(model);
  EXPECT_EQ(files.cameras, kEdgeCameras);
  EXPECT_EQ(files.images, kEdgeImages);
  EXPECT_EQ(files.points3D, kEdgePoints3D);
}

TEST(ModelIoTextTest, SkipsCommentsAndBlankLinesBetweenImages) {
  // Windows line ends too; the line after an image line is its POINTS2D
  // line even when empty.
  const std::string images =
      "# comment\r\n"
      "\r\n"
      "4 1 0 0 0 0 0 0 4 b\r\n"
      "\r\n"
      "# another comment\n"
      "\n"
      "5 1 0 0 0 0 0 0 4 c\n"
      "1 2 -1\n";
  ColmapModel model;
  std::istringstream stream(images);
  ReadImagesText(model, stream);
  ASSERT_EQ(model.images.size(), 2u);
  EXPECT_EQ(model.images[0].name, "b");
  EXPECT_TRUE(model.images[0].points2D.empty());
  EXPECT_EQ(model.images[1].points2D.size(), 1u);
}

TEST(ModelIoTextTest, ParsesFieldsAsColmapDoes) {
  const std::string images =
      "3  +0.5\t0.5 0.5 0.5   1e2 -2.5E-3 0 4 a name with spaces \r\n"
      "1.5 2 -1   3 4 18446744073709551615 5 6 77\r\n"
      "4 1 0 0 0 0 0 0 4 b\n"
      "\n";
  ColmapModel model;
  std::istringstream stream(images);
  ReadImagesText(model, stream);
  ASSERT_EQ(model.images.size(), 2u);
  const ColmapImage& image = model.images[0];
  EXPECT_EQ(image.qvec, Eigen::Vector4d(0.5, 0.5, 0.5, 0.5));
  EXPECT_EQ(image.tvec, Eigen::Vector3d(100, -2.5e-3, 0));
  EXPECT_EQ(image.name, "a name with spaces");
  ASSERT_EQ(image.points2D.size(), 3u);
  EXPECT_FALSE(image.points2D[0].HasPoint3D());
  EXPECT_FALSE(image.points2D[1].HasPoint3D());
  EXPECT_EQ(image.points2D[2].point3D_id, 77u);
  EXPECT_TRUE(model.images[1].points2D.empty());
}

TEST(ModelIoTextTest, BadLinesNameTheLineAndField) {
  EXPECT_EQ(ErrorOf("# header\n\n1 abc 0 0 0 0 0 0 1 x\n\n", kReadImages),
            "images.txt:3: field 'image 1 QW' = \"abc\": expected a real "
            "number");
  EXPECT_EQ(ErrorOf("1 1 0 0 0 0 0 0 1 x\n1 2 3 4\n", kReadImages),
            "images.txt:2: field 'image 1 POINTS2D' = 4 values: expected "
            "triples X, Y, POINT3D_ID");
  EXPECT_EQ(ErrorOf("1 1 0 0 0 0 0 0 1 x\n1 2 -2\n", kReadImages),
            "images.txt:2: field 'image 1 point2D 0 POINT3D_ID (or -1)' = "
            "\"-2\": expected an integer from 0 to 18446744073709551615");
  EXPECT_NE(ErrorOf("1 1 0 0 0 0 0 0 1 x", kReadImages)
                .find("images.txt:1: field 'image 1 POINTS2D': the file ends"),
            std::string::npos);
  EXPECT_NE(ErrorOf("1 1 0 0 0 0 0 1\n\n", kReadImages)
                .find("8 values: expected IMAGE_ID"),
            std::string::npos);
  EXPECT_EQ(ErrorOf("1 PINHOLE 640 480 1 2 3\n", kReadCameras),
            "cameras.txt:1: field 'camera 1 PARAMS' = 3 values: PINHOLE "
            "takes 4");
  EXPECT_EQ(ErrorOf("1 PINHOLE_X 640 480 1 2 3\n", kReadCameras),
            "cameras.txt:1: field 'camera 1 MODEL' = \"PINHOLE_X\": not a "
            "COLMAP 3.8 camera model name");
  EXPECT_NE(ErrorOf("1 PINHOLE 640.5 480 1 2 3 4\n", kReadCameras)
                .find("field 'camera 1 WIDTH' = \"640.5\""),
            std::string::npos);
  EXPECT_NE(ErrorOf("4294967296 PINHOLE 1 1 1 2 3 4\n", kReadCameras)
                .find("expected an integer from 0 to 4294967295"),
            std::string::npos);
  EXPECT_NE(ErrorOf("1 PINHOLE 1 1 1 2 3 1e999\n", kReadCameras)
                .find("field 'camera 1 PARAMS[3]' = \"1e999\""),
            std::string::npos);
  EXPECT_EQ(ErrorOf("\n\n9 1 2 3 10 20 256 0.5\n", kReadPoints),
            "points3D.txt:3: field 'point3D 9 B' = \"256\": expected an "
            "integer from 0 to 255");
  EXPECT_NE(ErrorOf("9 1 2 3 10 20 30 0.5 1\n", kReadPoints)
                .find("field 'point3D 9 TRACK' = 1 values: expected pairs"),
            std::string::npos);
}

TEST(ModelIoTextTest, RefusesNamesItCouldNotReadBack) {
  ColmapModel model = BuildModel();
  std::ostringstream out;
  model.images[2].name = "two\nlines";
  EXPECT_THROW(WriteImagesText(model, out), Error);
  model.images[2].name = " leading";
  EXPECT_THROW(WriteImagesText(model, out), Error);
  model.images[2].name = "trailing\t";
  EXPECT_THROW(WriteImagesText(model, out), Error);
  model.images[2].name = "";
  EXPECT_NO_THROW(WriteImagesText(model, out));
}

// A model with a repeated image id, or a point2D that names a missing 3D
// point, is read with one warning that names the folder and the id.
TEST(ModelIoTextTest, RepeatedIdsAndDanglingReferencesAreSaidOnce) {
  for (const bool repeat : {true, false}) {
    ColmapModel model = BuildModel();
    if (repeat) {
      model.images[3].image_id = model.images[2].image_id;
    } else {
      model.images[1].points2D.push_back({{1.0, 2.0}, 424242});
    }
    testing::TempDir dir;
    WriteModel(model, dir.path(), ColmapFormat::kText);
    std::ostringstream log;
    SetLogSink(&log);
    const ColmapModel read = ReadModel(dir.path());
    SetLogSink(nullptr);
    const std::string text = log.str();
    const std::string what =
        repeat ? "image id appears more than once" : "no 3D point has this id";
    EXPECT_NE(text.find(what), std::string::npos) << text;
    EXPECT_NE(text.find(dir.path().string()), std::string::npos) << text;
    EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << text;
    EXPECT_EQ(read.images.size(), model.images.size());
  }
}

TEST(ModelIoTextTest, TruncationNeverCrashes) {
  const Files files = WriteText(BuildModel());
  const std::pair<const std::string*, void (*)(ColmapModel&, std::istream&)>
      cases[] = {{&files.cameras, kReadCameras},
                 {&files.images, kReadImages},
                 {&files.points3D, kReadPoints}};
  for (const auto& [text, read] : cases) {
    for (std::size_t size = 0; size < text->size(); size += 7) {
      ColmapModel model;
      std::istringstream stream(text->substr(0, size));
      try {
        read(model, stream);
      } catch (const Error& error) {
        // A cut inside a line is a malformed line, named with its number.
        EXPECT_NE(std::string(error.what()).find(".txt:"), std::string::npos);
      }
    }
  }
}

}  // namespace
}  // namespace pano4d
