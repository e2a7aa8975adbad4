#include "momentum/model/inertial_corrections.hpp"

#include <cmath>
#include <cstdio>

#include <Eigen/Eigenvalues>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"

namespace momentum::model {

namespace {
constexpr const char* kSection = "inertial_corrections";
const char* const kNames[10] = {"m", "mx", "my", "mz", "ixx", "ixy", "ixz", "iyy", "iyz", "izz"};

[[noreturn]] void fail(const Profile& profile, const std::string& message) {
  throw Error(located(profile.path.string(), 0, message));
}
}  // namespace

StandardParameters standard_parameters(const Body& body) {
  const double m = body.mass;
  const Eigen::Vector3d& c = body.com;
  const Eigen::Matrix3d origin =
      body.inertia + m * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
  StandardParameters theta;
  theta << m, m * c.x(), m * c.y(), m * c.z(), origin(0, 0), origin(0, 1), origin(0, 2),
      origin(1, 1), origin(1, 2), origin(2, 2);
  return theta;
}

bool set_standard_parameters(Body& body, const StandardParameters& theta, std::string* why) {
  const double m = theta[0];
  if (!theta.allFinite()) return invalid(why, "parameters not finite");
  if (!(m > 0.0)) return invalid(why, "mass " + std::to_string(m) + " kg is not positive");
  const Eigen::Vector3d c = theta.segment<3>(1) / m;
  Eigen::Matrix3d origin;
  origin << theta[4], theta[5], theta[6], theta[5], theta[7], theta[8], theta[6], theta[8],
      theta[9];
  const Eigen::Matrix3d about_com =
      origin - m * (c.squaredNorm() * Eigen::Matrix3d::Identity() - c * c.transpose());
  std::string reason;
  if (!is_physical_inertia(about_com, &reason)) return invalid(why, "inertia about the centre of mass: " + reason);
  body.mass = m;
  body.com = c;
  body.inertia = about_com;
  return true;
}

std::vector<std::pair<std::string, StandardParameters>> read_inertial_corrections(
    const Profile& profile) {
  std::vector<std::pair<std::string, StandardParameters>> out;
  const auto it = profile.document.find(kSection);
  if (it == profile.document.end() || it->is_null()) return out;
  if (!it->is_object()) fail(profile, "\"inertial_corrections\" must be an object");
  const auto bodies = it->find("bodies");
  if (bodies == it->end()) return out;
  if (!bodies->is_object()) {
    fail(profile, "\"inertial_corrections\".bodies must be an object of body names");
  }
  for (const auto& item : bodies->items()) {
    const std::string where = "\"inertial_corrections\".bodies." + item.key();
    const auto& value = item.value();
    if (!value.is_array() || value.size() != 10) {
      fail(profile, where + " must be an array of 10 numbers (m, mx, my, mz, ixx, ixy, ixz, iyy, iyz, izz)");
    }
    StandardParameters delta;
    for (int k = 0; k < 10; ++k) {
      const auto& x = value[static_cast<std::size_t>(k)];
      if (!x.is_number() || !std::isfinite(x.get<double>())) {
        fail(profile, where + "[" + std::to_string(k) + "] must be a finite number");
      }
      delta[k] = x.get<double>();
    }
    out.emplace_back(item.key(), delta);
  }
  return out;
}

void apply_inertial_corrections(const Profile& profile, Model& model) {
  for (const auto& [name, delta] : read_inertial_corrections(profile)) {
    Body* body = nullptr;
    for (Body& b : model.bodies) {
      if (b.name == name) body = &b;
    }
    if (!body) {
      fail(profile, "\"inertial_corrections\": '" + name + "' is not a moving body of the chain " +
                        model.root + " -> " + model.tip);
    }
    std::string why;
    if (!set_standard_parameters(*body, standard_parameters(*body) + delta, &why)) {
      fail(profile, "\"inertial_corrections\": body '" + name + "' is not physical once corrected: " + why);
    }
  }
}

Model build_nominal_model(const Profile& profile) {
  Profile nominal = profile;
  nominal.document.erase(kSection);
  return build_model(nominal);
}

nlohmann::json inertial_corrections_section(const Model& model, const Eigen::VectorXd& delta,
                                            const nlohmann::json& details) {
  nlohmann::json section = nlohmann::json::object();
  if (details.is_object()) section = details;
  section["parameters"] = nlohmann::json::array();
  for (const char* name : kNames) section["parameters"].push_back(name);
  nlohmann::json bodies = nlohmann::json::object();
  for (int k = 0; k < model.nq; ++k) {
    const Eigen::VectorXd d = delta.segment(10 * k, 10);
    if (d.isZero(0.0)) continue;
    nlohmann::json values = nlohmann::json::array();
    for (int j = 0; j < 10; ++j) values.push_back(d[j]);
    bodies[model.bodies[static_cast<std::size_t>(k)].name] = values;
  }
  section["bodies"] = bodies;
  return section;
}

std::string describe_corrections(const Model& nominal, const Model& corrected) {
  auto num = [](double x) { return core::significant(x, 6); };  // -0 stays "-0", as printf wrote it
  auto triple = [&](const Eigen::Vector3d& v) { return num(v.x()) + " " + num(v.y()) + " " + num(v.z()); };
  auto principal = [&](const Eigen::Matrix3d& inertia) {
    return triple(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(inertia, Eigen::EigenvaluesOnly).eigenvalues());
  };
  std::string out = "inertial corrections (mo-dynfit): nominal URDF -> corrected\n";
  char line[512];
  for (std::size_t k = 0; k < nominal.bodies.size() && k < corrected.bodies.size(); ++k) {
    const Body& a = nominal.bodies[k];
    const Body& b = corrected.bodies[k];
    std::snprintf(line, sizeof line, "  %-12s mass %s -> %s kg, com %s -> %s m, principal_inertia %s -> %s kg m^2\n",
                  a.name.c_str(), num(a.mass).c_str(), num(b.mass).c_str(), triple(a.com).c_str(),
                  triple(b.com).c_str(), principal(a.inertia).c_str(), principal(b.inertia).c_str());
    out += line;
  }
  out += "  total mass " + num(nominal.total_mass()) + " -> " + num(corrected.total_mass()) + " kg\n";
  return out;
}

}  // namespace momentum::model
