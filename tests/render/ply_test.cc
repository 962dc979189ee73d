#include "src/render/ply.h"

#include <cstring>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "src/core/error.h"

namespace pano4d {
namespace {

GaussianModel Random(int degree, int n) {
  std::mt19937 rng(degree * 7 + n);
  std::normal_distribution<float> u;
  GaussianModel m;
  m.sh_degree = degree;
  m.Resize(n);
  for (auto* v : {&m.means, &m.log_scales, &m.quats, &m.opacities, &m.sh}) {
    for (float& x : *v) x = u(rng);
  }
  return m;
}

std::string ErrorOf(const std::string& bytes) {
  std::istringstream in(bytes);
  try {
    ReadPly(in, "splat.ply");
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(PlyTest, RoundTripAtEveryShDegree) {
  for (int degree = 0; degree <= 3; ++degree) {
    const GaussianModel m = Random(degree, 17);
    std::stringstream buffer;
    WritePly(buffer, m);
    const GaussianModel back = ReadPly(buffer, "mem");
    EXPECT_EQ(back.sh_degree, degree);
    EXPECT_EQ(back.means, m.means);
    EXPECT_EQ(back.log_scales, m.log_scales);
    EXPECT_EQ(back.quats, m.quats);
    EXPECT_EQ(back.opacities, m.opacities);
    EXPECT_EQ(back.sh, m.sh);
  }
}

TEST(PlyTest, HeaderIsThe3dgsLayoutAndRestIsChannelMajor) {
  GaussianModel m = Random(0, 1);
  std::ostringstream out;
  WritePly(out, m);
  const std::string header =
      out.str().substr(0, out.str().find("end_header\n") + 11);
  EXPECT_EQ(
      header,
      "ply\nformat binary_little_endian 1.0\nelement vertex 1\n"
      "property float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\n"
      "property float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\n"
      "property float opacity\nproperty float scale_0\nproperty float scale_1\n"
      "property float scale_2\nproperty float rot_0\nproperty float rot_1\n"
      "property float rot_2\nproperty float rot_3\nend_header\n");

  // Degree 3: coefficient k = 1 of blue is f_rest_30 (channel-major: 15 per
  // channel), the 9 + 30 = 39th float of the row.
  m = Random(3, 1);
  std::fill(m.sh.begin(), m.sh.end(), 0.0f);
  m.sh[1 * 3 + 2] = 7.0f;
  std::ostringstream out3;
  WritePly(out3, m);
  const std::string bytes = out3.str();
  const std::size_t data = bytes.find("end_header\n") + 11;
  float value;
  std::memcpy(&value, bytes.data() + data + 39 * sizeof(float), sizeof(float));
  EXPECT_EQ(value, 7.0f);
}

TEST(PlyTest, ReadsPropertiesInAnyOrderAndIgnoresExtras) {
  std::string file =
      "ply\nformat binary_little_endian 1.0\ncomment written by hand\nelement "
      "vertex 1\n";
  const std::vector<std::string> names = {
      "rot_3",   "rot_2",   "rot_1",   "rot_0",  "scale_2",
      "scale_1", "scale_0", "opacity", "f_dc_2", "f_dc_1",
      "f_dc_0",  "z",       "y",       "x",      "extra"};
  for (const std::string& n : names) file += "property float " + n + "\n";
  file += "end_header\n";
  for (std::size_t i = 0; i < names.size(); ++i) {
    const float v = static_cast<float>(i);
    file.append(reinterpret_cast<const char*>(&v), sizeof(v));
  }
  std::istringstream in(file);
  const GaussianModel m = ReadPly(in, "hand.ply");
  EXPECT_EQ(m.means, (std::vector<float>{13, 12, 11}));
  EXPECT_EQ(m.quats, (std::vector<float>{3, 2, 1, 0}));
  EXPECT_EQ(m.opacities[0], 7.0f);
}

TEST(PlyTest, RejectsWhatItCannotRead) {
  EXPECT_NE(ErrorOf("solid cube\n").find("not a PLY file"), std::string::npos);
  EXPECT_NE(ErrorOf("ply\nformat ascii 1.0\nelement vertex 0\nend_header\n")
                .find("binary_little_endian"),
            std::string::npos);
  EXPECT_NE(ErrorOf("ply\nformat binary_little_endian 1.0\nelement vertex "
                    "1\nproperty float x\nend_header\n")
                .find("missing"),
            std::string::npos);
  std::ostringstream good;
  WritePly(good, Random(0, 3));
  std::string huge = good.str();
  huge.replace(huge.find("vertex 3"), 8, "vertex 99999999999999");
  EXPECT_NE(ErrorOf(huge).find("holds only"), std::string::npos);
  EXPECT_NE(
      ErrorOf(good.str().substr(0, good.str().size() - 5)).find("holds only"),
      std::string::npos);
  EXPECT_NE(ErrorOf("ply\nformat binary_little_endian 1.0\nelement vertex "
                    "1\nproperty double x\n")
                .find("float"),
            std::string::npos);
  EXPECT_NE(ErrorOf("ply\nformat binary_little_endian 1.0\nelement face 1\n")
                .find("vertex"),
            std::string::npos);
  EXPECT_NE(
      ErrorOf("ply\nformat binary_little_endian 1.0\n").find("ends inside"),
      std::string::npos);
}

}  // namespace
}  // namespace pano4d
