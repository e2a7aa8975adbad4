#include "momentum/friction/registry.hpp"

#include <iterator>
#include <string>
#include <vector>

namespace momentum::friction {

const char* kind_name(Kind kind) {
  return visit(kind, [](auto model) { return decltype(model)::kName; });
}

bool parse_kind(const std::string& name, Kind* kind) {
  for (Kind k : kKinds) {
    const bool match = visit(k, [&](auto model) {
      using Model = decltype(model);
      return name == Model::kName || (*Model::kAlias && name == Model::kAlias);
    });
    if (match) {
      *kind = k;
      return true;
    }
  }
  return false;
}

std::string kind_names_text(const char* first_note) {
  const std::size_t n = std::size(kKinds);
  std::string text;
  for (std::size_t i = 0; i < n; ++i) {
    if (i > 0) text += i + 1 == n ? " or " : ", ";
    text += kind_name(kKinds[i]);
    if (i == 0) text += first_note;
  }
  return text;
}

std::vector<int> used_parameters(Kind kind, bool asymmetry) {
  return visit(kind, [&](auto model) {
    using Model = decltype(model);
    std::vector<int> used(std::begin(Model::kParameters), std::end(Model::kParameters));
    if (asymmetry) used.insert(used.end(), std::begin(Model::kAsymmetry), std::end(Model::kAsymmetry));
    return used;
  });
}

std::vector<int> asymmetry_parameters(Kind kind) {
  return visit(kind, [](auto model) {
    using Model = decltype(model);
    return std::vector<int>(std::begin(Model::kAsymmetry), std::end(Model::kAsymmetry));
  });
}

bool must_be_positive(Kind kind, int i) {
  return visit(kind, [i](auto model) { return decltype(model)::must_be_positive(i); });
}

bool has_state(Kind kind) {
  return visit(kind, [](auto model) { return decltype(model)::kHasState; });
}

double sliding_level(Kind kind, const Parameters<double>& p, double w) {
  return visit(kind, [&](auto model) { return decltype(model)::sliding_level(p, w); });
}

void steady_gradient(Kind kind, const Parameters<double>& p, double w, double* gradient) {
  visit(kind, [&](auto model) { decltype(model)::steady_gradient(p, w, gradient); });
}

double affine_from(Kind kind, const Parameters<double>& p, double direction, double* constant, double* slope) {
  return visit(kind, [&](auto model) { return decltype(model)::affine_from(p, direction, constant, slope); });
}

bool IsValid(Kind kind, const Parameters<double>& p, std::string* why) {
  return visit(kind, [&](auto model) { return decltype(model)::IsValid(p, why); });
}

}  // namespace momentum::friction
