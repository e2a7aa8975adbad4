#include "momentum/friction/parameters.hpp"

#include <cmath>
#include <string>

#include "momentum/core/error.hpp"
#include "momentum/core/number.hpp"

namespace momentum::friction {
namespace {

double value(const Parameters<double>& p, int i) {
  double x[Parameters<double>::kSize];
  p.to_array(x);
  return x[i];
}

std::string named(const Parameters<double>& p, int i) {
  return std::string(kParameterNames[i]) + " = " + core::significant(value(p, i), 17);
}

}  // namespace

namespace check {

bool finite(const Parameters<double>& p, const int* first, const int* last, std::string* why) {
  for (const int* i = first; i != last; ++i)
    if (!std::isfinite(value(p, *i))) return invalid(why, std::string(kParameterNames[*i]) + " is not finite");
  return true;
}

bool not_negative(const Parameters<double>& p, int i, std::string* why) {
  return value(p, i) < 0 ? invalid(why, named(p, i) + " is negative") : true;
}

bool positive(const Parameters<double>& p, int i, std::string* why) {
  return !(value(p, i) > 0) ? invalid(why, named(p, i) + " is not positive") : true;
}

bool below(const Parameters<double>& p, int asymmetry, int level, std::string* why) {
  if (std::abs(value(p, asymmetry)) < value(p, level)) return true;
  return invalid(why, "|" + std::string(kParameterNames[asymmetry]) + "| = " + core::significant(std::abs(value(p, asymmetry)), 17) +
                       " is not below " + named(p, level) + " (the level of one direction would not be positive)");
}

bool not_above(const Parameters<double>& p, int asymmetry, int level, std::string* why) {
  if (!(std::abs(value(p, asymmetry)) > value(p, level))) return true;
  return invalid(why, "|" + std::string(kParameterNames[asymmetry]) + "| = " + core::significant(std::abs(value(p, asymmetry)), 17) +
                       " exceeds " + named(p, level) + " (a negative level in one direction)");
}

}  // namespace check

const char* update_name(LugreUpdate update) {
  return update == LugreUpdate::exact ? "exact" : "semi-implicit";
}

bool parse_update(const std::string& name, LugreUpdate* update) {
  if (name == "exact") *update = LugreUpdate::exact;
  else if (name == "semi-implicit" || name == "semi_implicit") *update = LugreUpdate::semi_implicit;
  else return false;
  return true;
}

}  // namespace momentum::friction
