#include "momentum/model/collision.hpp"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include "momentum/core/error.hpp"

namespace momentum::model {

namespace fs = std::filesystem;

std::optional<fs::path> resolve_mesh(const std::string& name, const fs::path& urdf) {
  auto existing = [](const fs::path& p) -> std::optional<fs::path> {
    std::error_code ec;
    if (fs::is_regular_file(p, ec)) return p;
    return std::nullopt;
  };
  constexpr std::string_view package = "package://", file = "file://";
  if (name.starts_with(package)) {
    const std::string rest = name.substr(package.size());
    if (const char* paths = std::getenv("ROS_PACKAGE_PATH")) {
      std::stringstream list(paths);
      for (std::string dir; std::getline(list, dir, ':');)
        if (!dir.empty())
          if (auto p = existing(fs::path(dir) / rest)) return p;
    }
    return std::nullopt;
  }
  if (name.starts_with(file)) return existing(name.substr(file.size()));
  const fs::path p(name);
  return existing(p.is_absolute() ? p : urdf.parent_path() / p);
}

namespace {

float read_float(const char* bytes) {
  float value;
  std::memcpy(&value, bytes, sizeof value);  // STL is little-endian, as every supported host
  return value;
}

std::vector<Eigen::Vector3d> read_ascii_stl(const std::string& text, const fs::path& path) {
  std::vector<Eigen::Vector3d> vertices;
  std::istringstream in(text);
  for (std::string word; in >> word;) {
    if (word != "vertex") continue;
    Eigen::Vector3d v;
    if (!(in >> v.x() >> v.y() >> v.z())) throw Error(path.string() + ": bad vertex in an ASCII STL");
    vertices.push_back(v);
  }
  if (vertices.size() % 3 != 0) throw Error(path.string() + ": an ASCII STL with an incomplete triangle");
  return vertices;
}

}  // namespace

std::vector<Eigen::Vector3d> read_stl(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path.string() + ": cannot open");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<Eigen::Vector3d> vertices;
  constexpr std::size_t kHeader = 80, kRecord = 50;
  std::uint32_t count = 0;
  if (bytes.size() >= kHeader + 4) std::memcpy(&count, bytes.data() + kHeader, 4);
  // A binary STL's size is exact; an ASCII one starts with "solid" (binary headers may too, so
  // the size decides first).
  if (bytes.size() >= kHeader + 4 && bytes.size() == kHeader + 4 + std::size_t{count} * kRecord) {
    vertices.reserve(std::size_t{count} * 3);
    for (std::uint32_t t = 0; t < count; ++t) {
      const char* record = bytes.data() + kHeader + 4 + std::size_t{t} * kRecord + 12;  // past the normal
      for (int v = 0; v < 3; ++v)
        vertices.emplace_back(read_float(record + 12 * v), read_float(record + 12 * v + 4), read_float(record + 12 * v + 8));
    }
  } else if (bytes.compare(0, 5, "solid") == 0) {
    vertices = read_ascii_stl(bytes, path);
  } else {
    throw Error(path.string() + ": not an STL file (a binary STL of " + std::to_string(count) + " triangles is " +
                std::to_string(kHeader + 4 + std::size_t{count} * kRecord) + " bytes, this one " +
                std::to_string(bytes.size()) + ")");
  }
  if (vertices.empty()) throw Error(path.string() + ": no triangle");
  for (const auto& v : vertices)
    if (!v.allFinite()) throw Error(path.string() + ": a vertex is not finite");
  return vertices;
}

}  // namespace momentum::model
