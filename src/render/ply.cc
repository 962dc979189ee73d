#include "src/render/ply.h"

#include <cstring>
#include <fstream>
#include <istream>
#include <map>
#include <ostream>
#include <sstream>
#include <vector>

#include "src/core/error.h"
#include "src/core/file.h"

namespace pano4d {
namespace {

// PLY headers of splat files are a few kilobytes; this bounds a corrupt one.
constexpr std::size_t kMaxHeaderBytes = 1 << 20;

std::vector<std::string> PropertyNames(int sh_degree) {
  std::vector<std::string> names = {"x",  "y",      "z",      "nx",    "ny",
                                    "nz", "f_dc_0", "f_dc_1", "f_dc_2"};
  const int rest = 3 * ((sh_degree + 1) * (sh_degree + 1) - 1);
  for (int i = 0; i < rest; ++i) names.push_back("f_rest_" + std::to_string(i));
  for (const char* n : {"opacity", "scale_0", "scale_1", "scale_2", "rot_0",
                        "rot_1", "rot_2", "rot_3"}) {
    names.emplace_back(n);
  }
  return names;
}

int DegreeFromRest(int rest, const std::string& source) {
  for (int degree = 0; degree <= 3; ++degree) {
    if (rest == 3 * ((degree + 1) * (degree + 1) - 1)) return degree;
  }
  throw Error(source, "f_rest_*", std::to_string(rest) + " properties",
              "expected 0, 9, 24 or 45 (SH degree 0 to 3)");
}

}  // namespace

void WritePly(std::ostream& out, const GaussianModel& model) {
  model.Check();
  const std::vector<std::string> names = PropertyNames(model.sh_degree);
  out << "ply\nformat binary_little_endian 1.0\nelement vertex " << model.size()
      << "\n";
  for (const std::string& name : names)
    out << "property float " << name << "\n";
  out << "end_header\n";
  const int k_count = model.sh_coefficients();
  std::vector<float> row(names.size());
  for (std::size_t i = 0; i < model.size(); ++i) {
    std::size_t c = 0;
    for (int a = 0; a < 3; ++a) row[c++] = model.means[3 * i + a];
    row[c++] = 0;
    row[c++] = 0;
    row[c++] = 0;
    for (int ch = 0; ch < 3; ++ch) row[c++] = model.sh[(i * k_count) * 3 + ch];
    for (int ch = 0; ch < 3; ++ch) {
      for (int k = 1; k < k_count; ++k)
        row[c++] = model.sh[(i * k_count + k) * 3 + ch];
    }
    row[c++] = model.opacities[i];
    for (int a = 0; a < 3; ++a) row[c++] = model.log_scales[3 * i + a];
    for (int a = 0; a < 4; ++a) row[c++] = model.quats[4 * i + a];
    out.write(reinterpret_cast<const char*>(row.data()),
              static_cast<std::streamsize>(row.size() * sizeof(float)));
  }
}

void WritePly(const std::filesystem::path& path, const GaussianModel& model) {
  std::ostringstream buffer;
  WritePly(buffer, model);
  WriteFileAtomically(path, buffer.str());
}

namespace {

// A splat PLY's header: the vertex count and the float properties in order.
struct PlyHeader {
  std::int64_t count = -1;
  std::vector<std::string> properties;
};

PlyHeader ReadPlyHeader(std::istream& in, const std::string& source) {
  std::string line;
  std::size_t header_bytes = 0;
  const auto next = [&]() {
    if (!std::getline(in, line))
      throw Error::In(source, "ends inside the PLY header");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    header_bytes += line.size() + 1;
    if (header_bytes > kMaxHeaderBytes)
      throw Error::In(source, "PLY header is implausibly long");
    return line;
  };
  if (next() != "ply")
    throw Error::In(source, "not a PLY file (no 'ply' magic line)");
  PlyHeader header;
  bool in_vertex = false;
  while (next() != "end_header") {
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "format") {
      std::string format, version;
      words >> format >> version;
      if (format != "binary_little_endian") {
        throw Error(source, "format", format,
                    "only binary_little_endian PLY files are read");
      }
    } else if (keyword == "element") {
      std::string name;
      std::int64_t n = -1;
      words >> name >> n;
      if (name != "vertex") {
        throw Error(source, "element", name,
                    "only a 'vertex' element is expected in a splat file");
      }
      if (n < 0)
        throw Error(source, "element vertex", line,
                    "expected a non-negative count");
      header.count = n;
      in_vertex = true;
    } else if (keyword == "property") {
      std::string type, name;
      words >> type >> name;
      if (!in_vertex)
        throw Error(source, "property", name, "comes before 'element vertex'");
      if (type != "float" && type != "float32") {
        throw Error(source, "property " + name, type,
                    "splat properties must be float");
      }
      header.properties.push_back(name);
    } else if (keyword != "comment" && keyword != "obj_info") {
      throw Error(source, "header", line, "unexpected line in a PLY header");
    }
  }
  if (header.count < 0)
    throw Error::In(source, "PLY header has no 'element vertex'");
  return header;
}

// Refuses a vertex count the rest of the stream cannot hold, before
// anything is allocated for it.
void CheckVertexData(std::istream& in, const PlyHeader& header,
                     const std::string& source) {
  const std::streampos start = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff available = in.tellg() - start;
  in.seekg(start);
  const std::uint64_t stride = header.properties.size() * sizeof(float);
  if (static_cast<std::uint64_t>(header.count) >
      static_cast<std::uint64_t>(available) /
          std::max<std::uint64_t>(stride, 1)) {
    throw Error(source, "element vertex", std::to_string(header.count),
                "the file holds only " + std::to_string(available) +
                    " bytes of vertex data");
  }
}

}  // namespace

GaussianModel ReadPly(std::istream& in, const std::string& source) {
  const PlyHeader header = ReadPlyHeader(in, source);
  const std::vector<std::string>& properties = header.properties;
  std::map<std::string, std::size_t> column;
  int rest = 0;
  for (std::size_t i = 0; i < properties.size(); ++i) {
    column[properties[i]] = i;
    rest += properties[i].rfind("f_rest_", 0) == 0 ? 1 : 0;
  }
  GaussianModel model;
  model.sh_degree = DegreeFromRest(rest, source);
  for (const std::string& name : PropertyNames(model.sh_degree)) {
    if (name[0] == 'n' && name.size() == 2) continue;  // normals are optional
    if (!column.count(name))
      throw Error(source, "property", name, "missing from the PLY header");
  }
  CheckVertexData(in, header, source);
  const std::int64_t count = header.count;
  model.Resize(static_cast<std::size_t>(count));
  const int k_count = model.sh_coefficients();
  std::vector<float> row(properties.size());
  const auto at = [&](const char* name) { return row[column.at(name)]; };
  for (std::int64_t i = 0; i < count; ++i) {
    if (!in.read(reinterpret_cast<char*>(row.data()),
                 static_cast<std::streamsize>(row.size() * sizeof(float)))) {
      throw Error::In(source, "vertex data ends early");
    }
    const char* axes[] = {"x", "y", "z"};
    const char* scales[] = {"scale_0", "scale_1", "scale_2"};
    for (int a = 0; a < 3; ++a) {
      model.means[3 * i + a] = at(axes[a]);
      model.log_scales[3 * i + a] = at(scales[a]);
      model.sh[(i * k_count) * 3 + a] =
          at(("f_dc_" + std::to_string(a)).c_str());
    }
    for (int ch = 0; ch < 3; ++ch) {
      for (int k = 1; k < k_count; ++k) {
        model.sh[(i * k_count + k) * 3 + ch] = row[column.at(
            "f_rest_" + std::to_string(ch * (k_count - 1) + k - 1))];
      }
    }
    model.opacities[i] = at("opacity");
    for (int a = 0; a < 4; ++a)
      model.quats[4 * i + a] = at(("rot_" + std::to_string(a)).c_str());
  }
  return model;
}

GaussianModel ReadPly(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw Error::In(path.string(), std::filesystem::exists(path)
                                       ? "cannot be opened"
                                       : "does not exist");
  return ReadPly(in, path.string());
}

}  // namespace pano4d
