#include "solver/stepper.hpp"

#include <stdexcept>

namespace bondem {

Stepper::Stepper(Scene& scene, PairFlag pair_flag)
    : scene_(scene), pair_flag_(std::move(pair_flag)) {
  if (scene_.criterion == BondCriterion::kPairFlag && !pair_flag_) {
    throw std::invalid_argument("bond criterion 'pair flag' needs a pair-flag supplier");
  }
  compute_forces();
}

template <class Adhesion>
ContactSummary Stepper::dispatch_criterion(Adhesion adhesion) {
  Particles& p = scene_.particles;
  switch (scene_.criterion) {
    case BondCriterion::kAlways:
      return accumulate_contact_forces(p, scene_, pairs_, adhesion,
                                       [](std::size_t, std::size_t) { return true; });
    case BondCriterion::kNever:
      return accumulate_contact_forces(p, scene_, pairs_, adhesion,
                                       [](std::size_t, std::size_t) { return false; });
    case BondCriterion::kPairFlag:
      return accumulate_contact_forces(
          p, scene_, pairs_, adhesion,
          [&](std::size_t i, std::size_t j) { return pair_flag_(p.id[i], p.id[j]); });
  }
  return {};
}

void Stepper::compute_forces() {
  Particles& p = scene_.particles;
  const std::size_t n = p.size();
  for (std::size_t i = 0; i < n; ++i) {
    p.fx[i] = p.mass[i] * scene_.gravity.x();
    p.fy[i] = p.mass[i] * scene_.gravity.y();
    p.fz[i] = p.mass[i] * scene_.gravity.z();
  }
  find_pairs_all(p, 0.0, pairs_);
  contacts_ = scene_.alpha == 1.0 ? dispatch_criterion(LinearAdhesion{})
                                  : dispatch_criterion(GeneralAdhesion{scene_.alpha});
}

void Stepper::step() {
  Particles& p = scene_.particles;
  const double dt = scene_.time_step;
  const double half_dt = 0.5 * dt;
  const std::size_t n = p.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double kick = half_dt * p.inv_mass[i];
    p.vx[i] += kick * p.fx[i];
    p.vy[i] += kick * p.fy[i];
    p.vz[i] += kick * p.fz[i];
    p.x[i] += dt * p.vx[i];
    p.y[i] += dt * p.vy[i];
    p.z[i] += dt * p.vz[i];
  }
  compute_forces();
  for (std::size_t i = 0; i < n; ++i) {
    const double kick = half_dt * p.inv_mass[i];
    p.vx[i] += kick * p.fx[i];
    p.vy[i] += kick * p.fy[i];
    p.vz[i] += kick * p.fz[i];
  }
  time_ = static_cast<double>(++step_count_) * dt;
}

}  // namespace bondem
