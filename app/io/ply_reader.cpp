#include "io/ply_reader.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include "common/error.h"

namespace cofusion::ply {
namespace {

enum class Format { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

// A scalar type: its size in bytes and kind ('i' signed, 'u' unsigned, 'f' floating point).
struct ScalarType {
  int size = 4;
  char kind = 'f';
};

bool parse_type(const std::string& name, ScalarType& type) {
  static const struct {
    const char* name;
    ScalarType type;
  } kTypes[] = {{"char", {1, 'i'}},   {"int8", {1, 'i'}},    {"uchar", {1, 'u'}},  {"uint8", {1, 'u'}},
                {"short", {2, 'i'}},  {"int16", {2, 'i'}},   {"ushort", {2, 'u'}}, {"uint16", {2, 'u'}},
                {"int", {4, 'i'}},    {"int32", {4, 'i'}},   {"uint", {4, 'u'}},   {"uint32", {4, 'u'}},
                {"float", {4, 'f'}},  {"float32", {4, 'f'}}, {"double", {8, 'f'}}, {"float64", {8, 'f'}}};
  for (const auto& t : kTypes)
    if (name == t.name) {
      type = t.type;
      return true;
    }
  return false;
}

struct Property {
  std::string name;
  ScalarType type;  // of the value, or of a list's items
  bool is_list = false;
  ScalarType count_type;  // of a list's length
};

struct Element {
  std::string name;
  std::size_t count = 0;
  std::vector<Property> properties;
};

struct Header {
  Format format = Format::kAscii;
  std::vector<Comment> comments;
  std::vector<Element> elements;
  std::size_t data_offset = 0;  // first byte after end_header's line
};

// One binary scalar as double, in the file's byte order.
double decode_binary(const unsigned char* p, ScalarType t, bool big_endian) {
  unsigned char b[8];
  std::memcpy(b, p, static_cast<std::size_t>(t.size));
  if (big_endian != (std::endian::native == std::endian::big)) std::reverse(b, b + t.size);
  switch (t.size) {
    case 1: return t.kind == 'i' ? static_cast<double>(static_cast<std::int8_t>(b[0])) : static_cast<double>(b[0]);
    case 2: {
      std::uint16_t v;
      std::memcpy(&v, b, 2);
      return t.kind == 'i' ? static_cast<double>(static_cast<std::int16_t>(v)) : static_cast<double>(v);
    }
    case 4: {
      std::uint32_t v;
      std::memcpy(&v, b, 4);
      if (t.kind == 'f') return static_cast<double>(std::bit_cast<float>(v));
      return t.kind == 'i' ? static_cast<double>(static_cast<std::int32_t>(v)) : static_cast<double>(v);
    }
    default: {
      double d;
      std::memcpy(&d, b, 8);
      return d;
    }
  }
}

Property parse_property(std::istringstream& ss, const std::string& at) {
  Property p;
  std::string type;
  ss >> type;
  if (type == "list") {
    std::string count_type, item_type;
    ss >> count_type >> item_type >> p.name;
    p.is_list = true;
    if (!parse_type(count_type, p.count_type) || !parse_type(item_type, p.type) || p.count_type.kind == 'f')
      throw Error(at + "bad list property");
  } else {
    if (!parse_type(type, p.type)) throw Error(at + "unknown property type '" + type + "'");
    ss >> p.name;
  }
  if (p.name.empty()) throw Error(at + "malformed property line");
  return p;
}

Element parse_element(std::istringstream& ss, const std::string& at) {
  Element e;
  std::string count;
  ss >> e.name >> count;
  std::size_t value = 0;
  const auto [ptr, ec] = std::from_chars(count.data(), count.data() + count.size(), value);
  if (e.name.empty() || ec != std::errc() || ptr != count.data() + count.size())
    throw Error(at + "expected 'element <name> <count>', bad element count '" + count + "'");
  e.count = value;
  return e;
}

Header parse_header(const std::string& data, const std::string& file) {
  std::size_t pos = 0;
  int line_no = 0;
  std::string line;
  const auto next_line = [&] {
    if (pos >= data.size()) return false;
    const std::size_t nl = data.find('\n', pos);
    if (nl == std::string::npos) return false;
    line = data.substr(pos, nl - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = nl + 1;
    ++line_no;
    return true;
  };
  if (!next_line() || line != "ply") throw Error(file + ": not a PLY file (first line is not 'ply')");
  Header h;
  bool have_format = false, have_end = false;
  while (!have_end && next_line()) {
    const std::string at = file + ":" + std::to_string(line_no) + ": ";
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    if (key.empty() || key == "obj_info") continue;
    if (key == "end_header") {
      have_end = true;
    } else if (key == "comment") {
      const std::size_t start = line.find_first_not_of(' ', line.find("comment") + 7);
      h.comments.push_back({line_no, start == std::string::npos ? "" : line.substr(start)});
    } else if (key == "format") {
      std::string f;
      ss >> f;
      if (f == "ascii") h.format = Format::kAscii;
      else if (f == "binary_little_endian") h.format = Format::kBinaryLittleEndian;
      else if (f == "binary_big_endian") h.format = Format::kBinaryBigEndian;
      else throw Error(at + "unknown PLY format '" + f + "'");
      have_format = true;
    } else if (key == "element") {
      h.elements.push_back(parse_element(ss, at));
    } else if (key == "property") {
      if (h.elements.empty()) throw Error(at + "property before any element");
      h.elements.back().properties.push_back(parse_property(ss, at));
    } else {
      throw Error(at + "unknown header keyword '" + key + "'");
    }
  }
  if (!have_end) throw Error(file + ": PLY header has no end_header line");
  if (!have_format) throw Error(file + ": PLY header has no format line");
  h.data_offset = pos;
  return h;
}

// Walks the elements' data up to and including the vertex element, handing each vertex
// property's value to the table.
class DataReader {
 public:
  DataReader(const std::string& data, const Header& h, const std::string& file)
      : data_(data), h_(h), file_(file), at_(h.data_offset) {}

  void read(VertexTable& table, const Element& vertex, const std::vector<int>& column_of) {
    for (const Element& e : h_.elements) {
      const bool is_vertex = &e == &vertex;
      // An element without properties has no data, whatever its count says.
      if (e.properties.empty()) continue;
      for (std::size_t n = 0; n < e.count; ++n)
        for (std::size_t k = 0; k < e.properties.size(); ++k) {
          const Property& p = e.properties[k];
          if (p.is_list) {
            skip_list(p, e.name, n);
            continue;
          }
          const double v = scalar(p.type, e.name, n);
          if (is_vertex && column_of[k] >= 0) table.values[n * table.columns.size() + size_t(column_of[k])] = v;
        }
      if (is_vertex) return;  // later elements are not needed
    }
  }

 private:
  std::string where(const std::string& element, std::size_t instance) const {
    return file_ + ": " + element + " " + std::to_string(instance);
  }

  double scalar(ScalarType t, const std::string& element, std::size_t instance) {
    if (h_.format == Format::kAscii) {
      const char* end = data_.data() + data_.size();
      const char* cur = data_.data() + at_;
      while (cur < end && std::isspace(static_cast<unsigned char>(*cur))) ++cur;
      double v = 0;
      const auto [ptr, ec] = std::from_chars(cur, end, v);
      if (ec != std::errc() || ptr == cur) throw Error(where(element, instance) + ": expected a number (truncated or malformed data)");
      at_ = static_cast<std::size_t>(ptr - data_.data());
      return v;
    }
    if (data_.size() - at_ < static_cast<std::size_t>(t.size))
      throw Error(file_ + ": truncated data at " + element + " " + std::to_string(instance));
    const double v = decode_binary(reinterpret_cast<const unsigned char*>(data_.data()) + at_, t,
                                   h_.format == Format::kBinaryBigEndian);
    at_ += static_cast<std::size_t>(t.size);
    return v;
  }

  void skip_list(const Property& p, const std::string& element, std::size_t instance) {
    const double len = scalar(p.count_type, element, instance);
    if (len < 0 || len != std::floor(len)) throw Error(where(element, instance) + ": bad list length");
    // Every item takes at least a byte: a longer list is truncated data (and no count is cast
    // beyond the integers' range).
    if (len > static_cast<double>(data_.size() - at_))
      throw Error(where(element, instance) + ": list of " + std::to_string(len) + " items runs past the end of the file");
    for (std::size_t m = 0; m < static_cast<std::size_t>(len); ++m) scalar(p.type, element, instance);
  }

  const std::string& data_;
  const Header& h_;
  const std::string& file_;
  std::size_t at_;
};

}  // namespace

VertexTable read_vertices(const std::filesystem::path& path, const std::vector<std::string>& columns) {
  const std::string file = path.string();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open PLY file " + file);
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const Header h = parse_header(data, file);
  const auto vertex = std::find_if(h.elements.begin(), h.elements.end(), [](const Element& e) { return e.name == "vertex"; });
  if (vertex == h.elements.end()) throw Error(file + ": no 'vertex' element");

  VertexTable table;
  table.comments = h.comments;
  table.count = vertex->count;
  table.columns = columns;
  table.present.assign(columns.size(), false);
  std::vector<int> column_of(vertex->properties.size(), -1);
  for (std::size_t k = 0; k < vertex->properties.size(); ++k) {
    const Property& p = vertex->properties[k];
    const auto c = std::find(columns.begin(), columns.end(), p.name);
    if (p.is_list || c == columns.end()) continue;
    column_of[k] = static_cast<int>(c - columns.begin());
    table.present[size_t(column_of[k])] = true;
  }
  for (const char* axis : {"x", "y", "z"}) {
    const auto c = std::find(columns.begin(), columns.end(), axis);
    if (c == columns.end() || !table.present[size_t(c - columns.begin())])
      throw Error(file + ": the vertex element lacks x, y or z");
  }
  // Every vertex takes at least a byte of the file: the file's size bounds the count before
  // anything is allocated.
  if (vertex->count > data.size() - h.data_offset) throw Error(file + ": truncated vertex data");
  table.values.assign(vertex->count * columns.size(), 0.0);
  DataReader(data, h, file).read(table, *vertex, column_of);
  return table;
}

}  // namespace cofusion::ply
