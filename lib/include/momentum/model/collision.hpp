#pragma once
// The URDF's collision meshes: where a mesh's file is, and its triangles. The shapes themselves
// are in Body::collision (model.hpp), read when the model is built.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace momentum::model {

// The file a URDF mesh name refers to: package://PKG/REST under a directory of ROS_PACKAGE_PATH
// (colon-separated) that holds PKG, or PKG/REST itself; file:///abs; a relative name relative
// to the URDF's directory. nullopt when no such file exists.
std::optional<std::filesystem::path> resolve_mesh(const std::string& name, const std::filesystem::path& urdf);

// The triangles of an STL file, binary or ASCII: 3 vertices per triangle, in the file's units.
// Throws momentum::Error ("file: message") when the file cannot be read, is truncated, holds a
// non-finite vertex or no triangle.
std::vector<Eigen::Vector3d> read_stl(const std::filesystem::path& path);

struct Model;

// One warning about the collision meshes of `model` that could not be read
// (Body::unread_meshes), or "" when there are none: the first such mesh, why (a package:// name
// with ROS_PACKAGE_PATH unset says to set it to the folder that holds the package; a file not
// found says where it was looked for; a file that is not a readable STL says why), how many
// more, and the bodies whose contacts are then located on their link segment instead.
std::string unread_meshes_warning(const Model& model);

}  // namespace momentum::model
