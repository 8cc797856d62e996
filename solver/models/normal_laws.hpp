#pragma once
/// @file normal_laws.hpp
/// The registry of normal-force laws: the one place that maps a run's choice to a compiled law.
///
/// To add a law (see CONTRIBUTING.md): write its header (the law object of normal_law.hpp and its
/// Spec of run-wide parameters with parameters()), add the Spec to NormalLawSpec and one line to
/// with_normal_law below, and read it in io/case_file.cpp. The kernels, the stepper and the
/// time-step rule need no change: they are written once against the law object.

#include <variant>

#include "solver/models/bond_normal_law.hpp"
#include "solver/models/hooke_law.hpp"

namespace bondem {

/// The normal-force law of a run with its run-wide parameters: one alternative per law.
using NormalLawSpec = std::variant<BondLawSpec, HookeLawSpec>;

namespace detail {
template <class... Ts>
struct Overloaded : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;
}  // namespace detail

/// Calls @p visit(law) with the law object of @p spec and returns what it returns (the same type
/// for every law). The kernels are compiled once per law object, here.
template <class Visit>
decltype(auto) with_normal_law(const NormalLawSpec& spec, Visit&& visit) {
  return std::visit(
      detail::Overloaded{
          [&](const BondLawSpec& /*bond*/) { return visit(BondNormalLaw{}); },
          [&](const HookeLawSpec& hooke) { return visit(HookeNormalLaw{hooke.stiffness}); },
      },
      spec);
}

/// Restitution of a contact with damping ratio @p xi under the normal law of @p spec.
inline double restitution_of(const NormalLawSpec& spec, double xi) {
  return with_normal_law(spec, [&](const auto& law) { return law.restitution_for(xi); });
}

/// Damping ratio whose restitution under the normal law of @p spec is @p restitution.
inline double damping_ratio_of(const NormalLawSpec& spec, double restitution) {
  return with_normal_law(spec, [&](const auto& law) { return law.damping_ratio_for(restitution); });
}

}  // namespace bondem
