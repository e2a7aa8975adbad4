// The profile's "inertial_corrections" section (written by mo-dynfit): additive corrections to
// the URDF's inertial parameters, per moving body, which build_model applies so that every tool
// uses the corrected model.
//
//   "inertial_corrections": {
//     "parameters": ["m", "mx", "my", "mz", "ixx", "ixy", "ixz", "iyy", "iyz", "izz"],
//     "bodies": {"upper_arm": [dm, dmx, dmy, dmz, dixx, dixy, dixz, diyy, diyz, dizz], ...}
//   }
//
// A body's standard parameters are its mass m (kg), first moment m c (kg m) and rotational
// inertia about the body ORIGIN (kg m^2), all in the body (= joint) frame of model.hpp; they
// are linear in the dynamics, so corrections add. Extra keys (e.g. mo-dynfit's fit metrics) are
// allowed. Schema: man 5 momentum-profile.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "momentum/model/model.hpp"
#include "momentum/model/profile.hpp"

namespace momentum::model {

using StandardParameters = Eigen::Matrix<double, 10, 1>;

// The standard parameters of a body (from mass, com, inertia about com).
StandardParameters standard_parameters(const Body& body);

// Sets a body's mass, com and inertia about the com from standard parameters. Returns false
// (body unchanged, reason in `why` when non-null) when they are not physical: mass not > 0,
// or the inertia about the com not positive definite or violating the triangle inequality.
bool set_standard_parameters(Body& body, const StandardParameters& theta, std::string* why);

// The section's corrections, one per body name, in the section's order. Throws momentum::Error
// naming the profile file when the section is malformed (not an object, "bodies" not an
// object of arrays of 10 finite numbers).
std::vector<std::pair<std::string, StandardParameters>> read_inertial_corrections(
    const Profile& profile);

// Applies the profile's corrections (if any) to `model` (built from the same profile without
// them). Throws momentum::Error naming the profile file when a body name is not a moving body
// of the chain or a corrected body is not physical.
void apply_inertial_corrections(const Profile& profile, Model& model);

// The model of the URDF as it is, without the profile's corrections (the payload still
// applies). Same errors as build_model.
Model build_nominal_model(const Profile& profile);

// A section for `model` (the nominal one): `delta` has 10 nq entries, body k's at 10 k; bodies
// whose correction is zero are left out. `details` (an object, may be null) is merged in.
nlohmann::json inertial_corrections_section(const Model& model, const Eigen::VectorXd& delta,
                                            const nlohmann::json& details);

// Text for mo-model: per body, mass, centre of mass and principal moments of inertia of the
// nominal model and of the corrected one side by side, then the total mass. Ends with a newline.
std::string describe_corrections(const Model& nominal, const Model& corrected);

}  // namespace momentum::model
