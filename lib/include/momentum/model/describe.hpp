// A human-readable description of a built chain, as mo-model prints it: how a user checks
// that the URDF, root, tip and drive parameters are what they meant before trusting the
// observer with them.
#pragma once

#include <string>

#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"

namespace momentum::model {

// Several lines ending in '\n': the robot and chain, gravity, one row per joint (name, type,
// axis, position limits, velocity and effort limits, k_i, rotor inertia), one row per body
// (mass, centre of mass, principal moments of inertia, merged links), the total moving mass,
// the tip placement, the locked joints, the active payload (mass, com in its link, principal
// moments, the body it joined) and the names of all payloads. Angles in rad (limits) and rad (rpy), lengths in m,
// masses in kg, inertias in kg m^2. Numbers are printed with 6 significant digits.
std::string describe_chain(const Model& model, const Profile& profile);

}  // namespace momentum::model
