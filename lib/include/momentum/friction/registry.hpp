// The friction models, listed once. Each model is one struct in its own header (lugre.hpp,
// stribeck.hpp, coulomb_viscous.hpp, ...) with the same static members:
//   kName, kAlias                     its name in the profile's JSON and for --model
//   kParameters[], kAsymmetry[]       the parameters it reads (indices, parameters.hpp order),
//                                     and the optional direction-asymmetry ones
//   kHasState                         an internal state z advanced by Options::update
//   must_be_positive(i), feasible(p), IsValid(p, why)    its physical bounds
//   start(p, w, z), step(p, w, dt, update, z)            its evaluation, templated on the scalar
//   sliding_level(p, w)               the friction level while sliding (a bristle state
//                                     saturates at sliding_level / sigma0)
//   steady(p, w), steady_gradient(p, w, g), affine_from(p, direction, constant, slope)
//                                     its steady state and the gradient the friction band needs
// The observer, the fitter, the report, the band, the profile's JSON and the tools reach the
// models only through the Kind below and visit(): a switch over the list, so a per-sample call
// costs a jump, not a virtual call (the observer steps friction on every row of every joint).
// A parameter means the same in every model that reads it (sigma0 is the bristle stiffness of
// LuGre and of Dahl), so its name, unit, default search box and the way that box scales to a
// robot are the parameter's, in parameters.hpp, and shared by those models.
//
// Adding a model: its header and its source (the parameter checks, IsValid), and one line in
// MOMENTUM_FRICTION_MODELS with its #include.
#pragma once

#include <string>
#include <vector>

#include "momentum/friction/coulomb_viscous.hpp"
#include "momentum/friction/dahl.hpp"
#include "momentum/friction/lugre.hpp"
#include "momentum/friction/parameters.hpp"
#include "momentum/friction/stribeck.hpp"

// X(enumerator, model struct), in the order the models are listed to the user; one line each.
#define MOMENTUM_FRICTION_MODELS(X)   \
  X(lugre, Lugre)                     \
  X(stribeck, Stribeck)               \
  X(coulomb_viscous, CoulombViscous)  \
  X(dahl, Dahl)                       \
  /* end of the list */

namespace momentum::friction {

// Which model a joint uses.
enum class Kind {
#define MOMENTUM_FRICTION_ENUMERATOR(kind, Model) kind,
  MOMENTUM_FRICTION_MODELS(MOMENTUM_FRICTION_ENUMERATOR)
#undef MOMENTUM_FRICTION_ENUMERATOR
};

// Calls f(Model{}) with the model struct of `kind` and returns what it returns (every model's
// call must return the same type).
template <class F>
decltype(auto) visit(Kind kind, F&& f) {
  switch (kind) {
#define MOMENTUM_FRICTION_CASE(kind, Model) \
  case Kind::kind:                          \
    return f(Model{});
    MOMENTUM_FRICTION_MODELS(MOMENTUM_FRICTION_CASE)
#undef MOMENTUM_FRICTION_CASE
  }
  __builtin_unreachable();
}

// Every model, in the order listed.
inline constexpr Kind kKinds[] = {
#define MOMENTUM_FRICTION_ITEM(kind, Model) Kind::kind,
    MOMENTUM_FRICTION_MODELS(MOMENTUM_FRICTION_ITEM)
#undef MOMENTUM_FRICTION_ITEM
};

// The model's name ("lugre", "stribeck", "coulomb-viscous", ...).
const char* kind_name(Kind kind);
// Inverse of kind_name (also accepts a model's alias, e.g. "coulomb_viscous"); false when unknown.
bool parse_kind(const std::string& name, Kind* kind);
// The names for a message: "lugre, stribeck or coulomb-viscous", `first_note` after the first
// name (e.g. " (default)").
std::string kind_names_text(const char* first_note = "");

// The parameters `kind` reads (indices in array order), with its asymmetry ones when
// `asymmetry`.
std::vector<int> used_parameters(Kind kind, bool asymmetry);
// The model's asymmetry parameters (optional in the JSON, 0 when absent).
std::vector<int> asymmetry_parameters(Kind kind);
// True when parameter i must be > 0 (not merely >= 0) for `kind`.
bool must_be_positive(Kind kind, int i);
// True when the model keeps a state advanced by Options::update (the JSON then has "update").
bool has_state(Kind kind);

// The model's friction level while sliding at w, Nm (>= 0 for valid parameters): a bristle
// state saturates at sliding_level / sigma0.
double sliding_level(Kind kind, const Parameters<double>& p, double w);
// The model's steady-friction gradient d|F(w)|/d(parameter) (8 values, array order) for the
// direction of w (w = 0: the positive side's limit).
void steady_gradient(Kind kind, const Parameters<double>& p, double w, double* gradient);
// The speed (rad/s, >= 0) beyond which that gradient is constant + slope |w| for `direction`
// (+1 or -1), with constant and slope (8 values each) written.
double affine_from(Kind kind, const Parameters<double>& p, double direction, double* constant, double* slope);

// Checks a parameter set for a model (the model's IsValid: finite numbers and its physical
// bounds). Returns false with the reason in `why` (when non-null).
bool IsValid(Kind kind, const Parameters<double>& p, std::string* why);

// The levels of both directions are positive (non-negative for Coulomb-viscous): outside this
// the friction model is meaningless (the LuGre rate would change sign).
template <class T>
bool feasible(Kind kind, const Parameters<T>& p) {
  return visit(kind, [&](auto model) { return decltype(model)::feasible(p); });
}

}  // namespace momentum::friction
