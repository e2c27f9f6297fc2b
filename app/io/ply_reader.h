#pragma once
// A reader for the vertex element of PLY files (ascii, binary little- and big-endian), shared by
// the surfel-model reader (export/ply_export.h) and the evaluation's point reader
// (eval/geometry_io.h).
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace cofusion::ply {

struct Comment {
  int line = 0;      // 1-based line of the header
  std::string text;  // what follows "comment " on that line
};

struct VertexTable {
  std::vector<Comment> comments;
  std::size_t count = 0;              // vertices
  std::vector<std::string> columns;   // the properties asked for
  std::vector<bool> present;          // per column: whether the file has it
  std::vector<double> values;         // count x columns, row-major; 0 where a column is absent

  double at(std::size_t vertex, std::size_t column) const { return values[vertex * columns.size() + column]; }
};

// Reads the header and the vertex element's scalar properties named in `columns` (any PLY scalar
// type, as double). Elements before the vertex element are skipped (list properties included);
// elements after it are not read. Throws cofusion::Error naming the file (and the header line
// where it applies) for a file that cannot be opened, is no PLY, has an unknown format, type or
// keyword, no end_header, no vertex element, a vertex element lacking x, y or z, or truncated or
// malformed data.
VertexTable read_vertices(const std::filesystem::path& path, const std::vector<std::string>& columns);

}  // namespace cofusion::ply
