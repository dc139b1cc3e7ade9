#include "dypho/mapping/gaussian_ply.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace dypho::mapping {
namespace {

std::vector<std::string> propertyNames(int K) {
  std::vector<std::string> names = {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"};
  for (int i = 0; i < 3 * (K - 1); ++i) names.push_back("f_rest_" + std::to_string(i));
  names.push_back("opacity");
  for (int i = 0; i < 3; ++i) names.push_back("scale_" + std::to_string(i));
  for (int i = 0; i < 4; ++i) names.push_back("rot_" + std::to_string(i));
  return names;
}

/// The error for a file that cannot be loaded: the path, then what is wrong.
std::runtime_error loadError(const std::string& path, const std::string& what) {
  return std::runtime_error("cannot load '" + path + "': " + what);
}

/// What the header of a 3DGS PLY declares.
struct PlyHeader {
  std::size_t count = 0;           ///< vertices (Gaussians)
  std::vector<std::string> props;  ///< names of the vertex properties, in file order (all float)
};

/// Reads the header after the 'ply' line up to and including 'end_header'; throws (loadError) on
/// a truncated header, another element with vertices in it, a non-float property, a format other
/// than binary little endian, or no vertex element.
PlyHeader readPlyHeader(std::istream& in, const std::string& path) {
  auto fail = [&](const std::string& what) { return loadError(path, what); };
  PlyHeader h;
  std::string line;
  bool in_vertex = false, have_vertex = false, binary_le = false;
  for (;;) {
    // A header line cut by the end of the file (no newline) is a truncated header too.
    if (!std::getline(in, line) || in.eof()) throw fail("header ends before 'end_header' (truncated file?)");
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "end_header") break;
    if (word == "format") {
      std::string fmt;
      ls >> fmt;
      binary_le = fmt == "binary_little_endian";
    } else if (word == "element") {
      std::string name;
      long long n = -1;
      ls >> name;
      if (!(ls >> n) || n < 0) throw fail("bad " + name + " count in '" + line + "'");
      in_vertex = name == "vertex";
      if (in_vertex) {
        h.count = static_cast<std::size_t>(n);
        have_vertex = true;
      } else if (n != 0) {
        throw fail("element '" + name + "' before/after the vertices is not supported (3DGS files have only vertices)");
      }
    } else if (word == "property" && in_vertex) {
      std::string type, name;
      ls >> type >> name;
      if (type != "float" && type != "float32") throw fail("property '" + name + "' is '" + type + "', expected float");
      h.props.push_back(name);
    }
  }
  if (!binary_le) throw fail("only 'format binary_little_endian 1.0' is supported (convert ASCII PLYs first)");
  if (!have_vertex) throw fail("no 'element vertex'");
  return h;
}

/// Where each parameter of a Gaussian sits in a row of the file.
struct PlyColumns {
  int file_K = 1;  ///< SH coefficients per channel in the file
  int kept_K = 1;  ///< of those, the ones the map keeps (min with the map's)
  std::size_t x[3], dc[3], opacity, scale[3], rot[4];
  /// rest[3 * k + ch]: the file's column of coefficient k (>= 1) of channel ch (channel-major).
  std::vector<std::size_t> rest;
};

/// Finds every value by its property's name (files from other tools may order them differently);
/// `map_K`: SH coefficients per channel of the map. Throws on duplicate or missing properties and
/// on an f_rest_* count that is no SH degree 0-3.
PlyColumns plyColumns(const std::vector<std::string>& props, int map_K, const std::string& path) {
  auto fail = [&](const std::string& what) { return loadError(path, what); };
  std::map<std::string, std::size_t> index;
  for (std::size_t i = 0; i < props.size(); ++i)
    if (!index.emplace(props[i], i).second) throw fail("property '" + props[i] + "' is declared twice");
  int rest = 0;
  while (index.count("f_rest_" + std::to_string(rest))) ++rest;
  if (rest % 3 != 0) throw fail("number of f_rest_* properties (" + std::to_string(rest) + ") is not a multiple of 3");
  PlyColumns c;
  const int file_K = c.file_K = rest / 3 + 1;
  if (file_K != 1 && file_K != 4 && file_K != 9 && file_K != 16) {
    throw fail(std::to_string(rest) + " f_rest_* properties do not match an SH degree 0-3 (0, 9, 24, 45)");
  }
  auto column = [&](const std::string& n) {
    const auto it = index.find(n);
    if (it == index.end()) throw fail("missing property '" + n + "'");
    return it->second;
  };
  c.x[0] = column("x"), c.x[1] = column("y"), c.x[2] = column("z");
  c.dc[0] = column("f_dc_0"), c.dc[1] = column("f_dc_1"), c.dc[2] = column("f_dc_2");
  c.opacity = column("opacity");
  for (int j = 0; j < 3; ++j) c.scale[j] = column("scale_" + std::to_string(j));
  for (int j = 0; j < 4; ++j) c.rot[j] = column("rot_" + std::to_string(j));
  const int kept_K = c.kept_K = std::min(map_K, file_K);
  c.rest.assign(static_cast<std::size_t>(3 * kept_K), 0);
  for (int ch = 0; ch < 3; ++ch)
    for (int k = 1; k < kept_K; ++k) c.rest[3 * k + ch] = column("f_rest_" + std::to_string(ch * (file_K - 1) + k - 1));
  return c;
}

/// Reads the payload of `count` rows of `stride` floats after the header; throws before
/// allocating when the file is too short for it.
std::vector<float> readPlyPayload(std::istream& in, std::size_t count, std::size_t stride, const std::string& path) {
  const std::size_t row_bytes = stride * sizeof(float);
  // Size check before touching the map or allocating: the payload must be complete. Division, not
  // multiplication, so that a hostile vertex count cannot overflow past the check.
  const std::streampos data_start = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff available = in.tellg() - data_start;
  in.seekg(data_start);
  if (available < 0 || count > static_cast<std::size_t>(available) / row_bytes) {
    throw loadError(path, "truncated: " + std::to_string(count) + " Gaussians of " + std::to_string(row_bytes) +
                              " bytes each need more data than the " + std::to_string(available) +
                              " bytes the file has");
  }
  std::vector<float> data(count * stride);
  in.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(count * row_bytes));
  if (!in) throw loadError(path, "read error");
  return data;
}

/// Counts of a load: rows added, and rows skipped for a non-finite value.
struct PlyLoadCounts {
  std::size_t loaded = 0, non_finite = 0;
};

/// Clears `map` (K SH coefficients per channel) and adds the finite rows of `data` ([count,
/// stride]) until it is full.
PlyLoadCounts addPlyRows(const std::vector<float>& data, std::size_t count, std::size_t stride, const PlyColumns& col,
                         int K, GaussianMap& map) {
  map.clear();
  PlyLoadCounts n;
  GaussianInit g;
  g.sh.assign(3 * K, 0.f);
  for (std::size_t i = 0; i < count; ++i) {
    const float* row = data.data() + i * stride;
    bool finite = true;
    for (std::size_t j = 0; j < stride; ++j) finite = finite && std::isfinite(row[j]);
    if (!finite) {
      ++n.non_finite;
      continue;
    }
    g.position_w = {row[col.x[0]], row[col.x[1]], row[col.x[2]]};
    g.opacity_logit = row[col.opacity];
    g.log_scale = {row[col.scale[0]], row[col.scale[1]], row[col.scale[2]]};
    g.rotation_wxyz = {row[col.rot[0]], row[col.rot[1]], row[col.rot[2]], row[col.rot[3]]};
    std::fill(g.sh.begin(), g.sh.end(), 0.f);
    for (int ch = 0; ch < 3; ++ch) g.sh[ch] = row[col.dc[ch]];
    for (int ch = 0; ch < 3; ++ch)
      for (int k = 1; k < col.kept_K; ++k) g.sh[3 * k + ch] = row[col.rest[3 * k + ch]];
    g.anchor_keyframe_id = -1;
    if (map.add(g) < 0) break;
    ++n.loaded;
  }
  return n;
}

/// What the load changed: SH degree adapted, Gaussians dropped or skipped (empty: nothing).
std::string plyLoadNote(int file_K, int map_K, int map_degree, std::size_t count, const PlyLoadCounts& n) {
  std::ostringstream os;
  if (file_K != map_K)
    os << "SH degree adapted from "
       << (file_K == 1   ? 0
           : file_K == 4 ? 1
           : file_K == 9 ? 2
                         : 3)
       << " to " << map_degree << "; ";
  if (n.loaded + n.non_finite < count)
    os << (count - n.loaded - n.non_finite) << " Gaussians beyond the capacity dropped; ";
  if (n.non_finite) os << n.non_finite << " Gaussians with non-finite values skipped; ";
  return os.str();
}

}  // namespace

void writeGaussianPly(std::ostream& out, const GaussianMap& map) {
  const int K = map.shCoeffs();
  const std::vector<std::string> names = propertyNames(K);
  out << "ply\nformat binary_little_endian 1.0\n"
      << "comment dypho_slam 3D Gaussian map (3DGS layout)\n"
      << "element vertex " << map.size() << "\n";
  for (const auto& n : names) out << "property float " << n << "\n";
  out << "end_header\n";
  std::vector<float> row(names.size());
  const float* pos = map.data(kParamPosition);
  const float* sc = map.data(kParamLogScale);
  const float* rot = map.data(kParamRotation);
  const float* op = map.data(kParamOpacity);
  const float* sh = map.data(kParamSh);
  for (std::size_t i = 0; i < map.size(); ++i) {
    std::size_t c = 0;
    for (int j = 0; j < 3; ++j) row[c++] = pos[3 * i + j];
    for (int j = 0; j < 3; ++j) row[c++] = 0.f;
    const float* s = sh + static_cast<std::size_t>(3 * K) * i;  // coefficient-major
    for (int ch = 0; ch < 3; ++ch) row[c++] = s[ch];
    for (int ch = 0; ch < 3; ++ch)
      for (int k = 1; k < K; ++k) row[c++] = s[3 * k + ch];
    row[c++] = op[i];
    for (int j = 0; j < 3; ++j) row[c++] = sc[3 * i + j];
    for (int j = 0; j < 4; ++j) row[c++] = rot[4 * i + j];
    out.write(reinterpret_cast<const char*>(row.data()), static_cast<std::streamsize>(row.size() * sizeof(float)));
  }
}

std::size_t readGaussianPly(const std::string& path, GaussianMap& map, std::string* note) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw loadError(path, "cannot open the file (does it exist?)");
  std::string line;
  if (!std::getline(in, line) || line != "ply") throw loadError(path, "not a PLY file (first line is not 'ply')");
  const PlyHeader header = readPlyHeader(in, path);
  const int K = map.shCoeffs();
  const PlyColumns columns = plyColumns(header.props, K, path);
  const std::size_t stride = header.props.size();
  const std::vector<float> data = readPlyPayload(in, header.count, stride, path);
  const PlyLoadCounts n = addPlyRows(data, header.count, stride, columns, K, map);
  if (note) *note = plyLoadNote(columns.file_K, K, map.shDegree(), header.count, n);
  return n.loaded;
}

}  // namespace dypho::mapping
