#include "src/core/npy.h"

#include <algorithm>
#include <bit>
#include <cstring>
#include <istream>
#include <iterator>
#include <limits>
#include <ostream>
#include <sstream>

#include <opencv2/core.hpp>

#include "src/core/error.h"
#include "src/core/file.h"

namespace pano4d {
namespace {

static_assert(std::endian::native == std::endian::little,
              "pano4d assumes a little-endian machine");

constexpr char kMagic[] = "\x93NUMPY";
constexpr std::size_t kMagicSize = 6;

// A strict reader of the Python dict literal in a .npy header, e.g.
//   {'descr': '<f4', 'fortran_order': False, 'shape': (480, 360, 1), }
class HeaderParser {
 public:
  HeaderParser(std::string_view text, const std::string& source)
      : text_(text), source_(source) {}

  void Parse(std::string* descr, bool* fortran_order,
             std::vector<std::int64_t>* shape) {
    bool have_descr = false, have_order = false, have_shape = false;
    Expect('{');
    while (true) {
      SkipSpaces();
      if (Peek() == '}') break;
      const std::string key = ParseString();
      Expect(':');
      if (key == "descr") {
        Once(&have_descr, key);
        *descr = ParseString();
      } else if (key == "fortran_order") {
        Once(&have_order, key);
        *fortran_order = ParseBool();
      } else if (key == "shape") {
        Once(&have_shape, key);
        *shape = ParseShape();
      } else {
        Fail("unexpected key '" + key + "'");
      }
      SkipSpaces();
      if (Peek() == ',') {
        ++pos_;
        continue;
      }
      if (Peek() != '}') Fail("expected ',' or '}'");
    }
    Expect('}');
    SkipSpaces();
    if (pos_ != text_.size()) Fail("unexpected text after the header dict");
    if (!have_descr || !have_order || !have_shape) {
      Fail("the header must hold 'descr', 'fortran_order' and 'shape'");
    }
  }

 private:
  [[noreturn]] void Fail(const std::string& what) const {
    throw Error(source_, "npy header", "byte " + std::to_string(pos_),
                "malformed .npy header: " + what);
  }
  char Peek() const { return pos_ < text_.size() ? text_[pos_] : '\0'; }
  void SkipSpaces() {
    while (pos_ < text_.size() &&
           (text_[pos_] == ' ' || text_[pos_] == '\n' || text_[pos_] == '\t' ||
            text_[pos_] == '\r')) {
      ++pos_;
    }
  }
  void Expect(char c) {
    SkipSpaces();
    if (Peek() != c) Fail(std::string("expected '") + c + "'");
    ++pos_;
  }
  void Once(bool* seen, const std::string& key) {
    if (*seen) Fail("duplicate key '" + key + "'");
    *seen = true;
  }
  std::string ParseString() {
    SkipSpaces();
    const char quote = Peek();
    if (quote != '\'' && quote != '"') Fail("expected a quoted string");
    const std::size_t end = text_.find(quote, pos_ + 1);
    if (end == std::string_view::npos) Fail("unterminated string");
    std::string value(text_.substr(pos_ + 1, end - pos_ - 1));
    pos_ = end + 1;
    return value;
  }
  bool ParseBool() {
    SkipSpaces();
    if (text_.substr(pos_, 4) == "True") {
      pos_ += 4;
      return true;
    }
    if (text_.substr(pos_, 5) == "False") {
      pos_ += 5;
      return false;
    }
    Fail("expected True or False");
  }
  std::int64_t ParseDimension() {
    SkipSpaces();
    const std::size_t start = pos_;
    std::int64_t value = 0;
    while (pos_ < text_.size() && text_[pos_] >= '0' && text_[pos_] <= '9') {
      const int digit = text_[pos_] - '0';
      if (value > (std::numeric_limits<std::int64_t>::max() - digit) / 10) {
        Fail("dimension too large");
      }
      value = value * 10 + digit;
      ++pos_;
    }
    if (pos_ == start) Fail("expected a non-negative integer dimension");
    if (Peek() == 'L') ++pos_;  // Python 2 long suffix, as old NumPy wrote
    return value;
  }
  std::vector<std::int64_t> ParseShape() {
    Expect('(');
    std::vector<std::int64_t> shape;
    bool trailing_comma = false;
    while (true) {
      SkipSpaces();
      if (Peek() == ')') break;
      shape.push_back(ParseDimension());
      SkipSpaces();
      trailing_comma = Peek() == ',';
      if (trailing_comma) {
        ++pos_;
        continue;
      }
      if (Peek() != ')') Fail("expected ',' or ')' in the shape");
    }
    Expect(')');
    if (shape.size() == 1 && !trailing_comma) {
      Fail("a 1-d shape must be written as a tuple, e.g. (5,)");
    }
    return shape;
  }

  std::string_view text_;
  const std::string& source_;
  std::size_t pos_ = 0;
};

void ParseDescr(const std::string& descr, const std::string& source,
                NpyArray* array, bool* swap_bytes) {
  const auto fail = [&]() {
    throw Error(source, "descr", "'" + descr + "'",
                "unsupported dtype; expected a bool, integer or float type "
                "such as '<f4'");
  };
  if (descr.size() < 3) fail();
  const char order = descr[0];
  const char kind = descr[1];
  int size = 0;
  for (std::size_t i = 2; i < descr.size(); ++i) {
    if (descr[i] < '0' || descr[i] > '9' || size > 8) fail();
    size = size * 10 + (descr[i] - '0');
  }
  const bool valid_size =
      (kind == 'f' && (size == 2 || size == 4 || size == 8)) ||
      ((kind == 'i' || kind == 'u') &&
       (size == 1 || size == 2 || size == 4 || size == 8)) ||
      (kind == 'b' && size == 1);
  if (!valid_size ||
      (order != '<' && order != '>' && order != '|' && order != '='))
    fail();
  if (order == '|' && size != 1) fail();
  array->kind = kind;
  array->item_size = size;
  *swap_bytes = order == '>' && size > 1;
}

template <typename T>
T Element(const std::uint8_t* p) {
  T value;
  std::memcpy(&value, p, sizeof(T));
  return value;
}

double ElementAsDouble(const NpyArray& a, std::int64_t i) {
  const std::uint8_t* p = a.data.data() + i * a.item_size;
  switch (a.kind) {
    case 'f':
      if (a.item_size == 2)
        return static_cast<float>(
            cv::float16_t::fromBits(Element<std::uint16_t>(p)));
      return a.item_size == 4 ? Element<float>(p) : Element<double>(p);
    case 'b':
      return p[0] != 0 ? 1.0 : 0.0;
    case 'i':
      switch (a.item_size) {
        case 1:
          return Element<std::int8_t>(p);
        case 2:
          return Element<std::int16_t>(p);
        case 4:
          return Element<std::int32_t>(p);
        default:
          return static_cast<double>(Element<std::int64_t>(p));
      }
    default:
      switch (a.item_size) {
        case 1:
          return p[0];
        case 2:
          return Element<std::uint16_t>(p);
        case 4:
          return Element<std::uint32_t>(p);
        default:
          return static_cast<double>(Element<std::uint64_t>(p));
      }
  }
}

std::string ShapeText(const std::vector<std::int64_t>& shape) {
  std::ostringstream out;
  out << "(";
  for (std::size_t i = 0; i < shape.size(); ++i) {
    out << shape[i] << (shape.size() == 1 || i + 1 < shape.size() ? "," : "");
    if (i + 1 < shape.size()) out << " ";
  }
  out << ")";
  return out.str();
}

template <typename T>
NpyArray FromValues(std::vector<std::int64_t> shape,
                    const std::vector<T>& values) {
  NpyArray array;
  array.kind = 'f';
  array.item_size = sizeof(T);
  array.shape = std::move(shape);
  if (array.size() != static_cast<std::int64_t>(values.size())) {
    throw Error("npy", "shape", ShapeText(array.shape),
                "holds " + std::to_string(array.size()) + " elements, got " +
                    std::to_string(values.size()) + " values");
  }
  array.data.resize(values.size() * sizeof(T));
  std::memcpy(array.data.data(), values.data(), array.data.size());
  return array;
}

}  // namespace

std::int64_t NpyArray::size() const {
  std::int64_t n = 1;
  for (const std::int64_t d : shape) n *= d;
  return n;
}

std::string NpyArray::descr() const {
  return std::string(item_size == 1 ? "|" : "<") + kind +
         std::to_string(item_size);
}

std::vector<double> NpyArray::ToDoubles() const {
  std::vector<double> out(static_cast<std::size_t>(size()));
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = ElementAsDouble(*this, i);
  return out;
}

std::vector<float> NpyArray::ToFloats() const {
  std::vector<float> out(static_cast<std::size_t>(size()));
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = static_cast<float>(ElementAsDouble(*this, i));
  }
  return out;
}

NpyArray NpyArray::FromFloats(std::vector<std::int64_t> shape,
                              const std::vector<float>& values) {
  return FromValues(std::move(shape), values);
}

NpyArray NpyArray::FromDoubles(std::vector<std::int64_t> shape,
                               const std::vector<double>& values) {
  return FromValues(std::move(shape), values);
}

NpyArray NpyArray::FromFloatsAsHalves(std::vector<std::int64_t> shape,
                                      const std::vector<float>& values) {
  std::vector<std::uint16_t> bits(values.size());
  for (std::size_t i = 0; i < values.size(); ++i)
    bits[i] = cv::float16_t(values[i]).bits();
  NpyArray array = FromValues(std::move(shape), bits);
  array.kind = 'f';
  return array;
}

NpyArray ParseNpy(const std::uint8_t* bytes, std::size_t size,
                  const std::string& source) {
  if (size < kMagicSize + 4 || std::memcmp(bytes, kMagic, kMagicSize) != 0) {
    throw Error::In(source,
                    "not a .npy file (the \\x93NUMPY magic is missing)");
  }
  const int major = bytes[6];
  std::size_t header_length = 0;
  std::size_t offset = 0;
  if (major == 1) {
    header_length = bytes[8] | (bytes[9] << 8);
    offset = 10;
  } else if (major == 2 || major == 3) {
    if (size < 12) throw Error::In(source, "truncated .npy header");
    header_length = static_cast<std::size_t>(bytes[8]) |
                    (static_cast<std::size_t>(bytes[9]) << 8) |
                    (static_cast<std::size_t>(bytes[10]) << 16) |
                    (static_cast<std::size_t>(bytes[11]) << 24);
    offset = 12;
  } else {
    throw Error(source, "npy version",
                std::to_string(major) + "." + std::to_string(bytes[7]),
                "unsupported .npy format version (expected 1.0, 2.0 or 3.0)");
  }
  if (header_length > kMaxNpyHeaderBytes) {
    throw Error(source, "npy header", std::to_string(header_length) + " bytes",
                "header length is implausible (corrupt file)");
  }
  if (header_length > size - offset) {
    throw Error(source, "npy header", std::to_string(header_length) + " bytes",
                "the file ends inside the header (truncated)");
  }
  const std::string_view header(reinterpret_cast<const char*>(bytes + offset),
                                header_length);

  NpyArray array;
  std::string descr;
  bool fortran_order = false;
  HeaderParser(header, source).Parse(&descr, &fortran_order, &array.shape);
  bool swap_bytes = false;
  ParseDescr(descr, source, &array, &swap_bytes);
  if (fortran_order && array.shape.size() > 1) {
    throw Error(source, "fortran_order", "True",
                "Fortran-order arrays are not supported; save with "
                "np.ascontiguousarray");
  }

  // The announced size must equal the bytes present; checked before any
  // allocation, with overflow-safe arithmetic.
  const std::size_t available = size - offset - header_length;
  std::size_t expected = static_cast<std::size_t>(array.item_size);
  for (const std::int64_t d : array.shape) {
    if (d != 0 && expected > available / static_cast<std::size_t>(d)) {
      throw Error(source, "shape", ShapeText(array.shape),
                  "announces more data than the file holds (" +
                      std::to_string(available) + " bytes after the header)");
    }
    expected *= static_cast<std::size_t>(d);
  }
  if (expected != available) {
    throw Error(source, "shape", ShapeText(array.shape),
                "announces " + std::to_string(expected) + " bytes of " + descr +
                    " data but " + std::to_string(available) +
                    " follow the header");
  }
  const std::uint8_t* data = bytes + offset + header_length;
  array.data.assign(data, data + available);
  if (swap_bytes) {
    for (std::size_t i = 0; i < array.data.size(); i += array.item_size) {
      std::reverse(array.data.begin() + i,
                   array.data.begin() + i + array.item_size);
    }
  }
  return array;
}

NpyArray ReadNpy(std::istream& in, const std::string& source) {
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                        std::istreambuf_iterator<char>());
  return ParseNpy(bytes.data(), bytes.size(), source);
}

NpyArray ReadNpy(const std::filesystem::path& path) {
  const std::vector<std::uint8_t> bytes = ReadFileBytes(path);
  return ParseNpy(bytes.data(), bytes.size(), path.string());
}

void WriteNpy(std::ostream& out, const NpyArray& array) {
  std::string header =
      "{'descr': '" + array.descr() +
      "', 'fortran_order': False, 'shape': " + ShapeText(array.shape) + ", }";
  // Pad with spaces so that magic + version + length + header + '\n' is a
  // multiple of 64 bytes, as NumPy does.
  const bool v2 = header.size() + 1 + 10 > 65535;
  const std::size_t prefix = v2 ? 12 : 10;
  header.append((64 - (prefix + header.size() + 1) % 64) % 64, ' ');
  header += '\n';
  out.write(kMagic, kMagicSize);
  const char version[2] = {static_cast<char>(v2 ? 2 : 1), 0};
  out.write(version, 2);
  const std::uint32_t length = static_cast<std::uint32_t>(header.size());
  out.write(reinterpret_cast<const char*>(&length), v2 ? 4 : 2);
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  out.write(reinterpret_cast<const char*>(array.data.data()),
            static_cast<std::streamsize>(array.data.size()));
}

void WriteNpy(const std::filesystem::path& path, const NpyArray& array) {
  std::ostringstream buffer;
  WriteNpy(buffer, array);
  WriteFileAtomically(path, buffer.str());
}

}  // namespace pano4d
