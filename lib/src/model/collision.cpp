#include "momentum/model/collision.hpp"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>

#include "momentum/core/error.hpp"
#include "momentum/model/model.hpp"

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

std::string unread_meshes_warning(const Model& model) {
  std::size_t count = 0;
  const std::string* first = nullptr;
  std::string bodies;
  for (const Body& body : model.bodies) {
    if (body.unread_meshes.empty()) continue;
    if (!first) first = &body.unread_meshes.front();
    count += body.unread_meshes.size();
    bodies += (bodies.empty() ? "'" : ", '") + body.name + "'";
  }
  if (!first) return "";
  const std::string& name = *first;
  std::string why;
  constexpr std::string_view package = "package://";
  if (auto file = resolve_mesh(name, model.urdf)) {
    try {
      read_stl(*file);
      why = "cannot be read";
    } catch (const Error& e) {
      why = std::string("cannot be read: ") + e.what();
    }
  } else if (name.starts_with(package)) {
    const std::string rest = name.substr(package.size());
    const std::string package_name = rest.substr(0, rest.find('/'));
    const char* paths = std::getenv("ROS_PACKAGE_PATH");
    why = paths && *paths ? "not found under ROS_PACKAGE_PATH=" + std::string(paths) +
                                ": add the folder that holds the package '" + package_name + "'"
                          : "not found: ROS_PACKAGE_PATH is not set; set it to the folder that holds the package '" +
                                package_name + "'";
  } else {
    const fs::path p(name.starts_with("file://") ? name.substr(7) : name);
    why = "not found (looked for " + (p.is_absolute() ? p : model.urdf.parent_path() / p).string() + ")";
  }
  std::string text = model.urdf.string() + ": collision mesh '" + name + "' " + why;
  if (count > 1) text += "; " + std::to_string(count - 1) + " more cannot be read either";
  return text + "; contacts on " + bodies + " are located around the link segment instead of on the meshes";
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
