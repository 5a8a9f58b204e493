// The right plus and minus of a Lie group (retract and localCoordinates), written once from the
// group's exp, log, compose and between: SE2, SO3 and SE3 define them alike.
#pragma once

namespace lslam::detail {

// a * Exp(tau). The Jacobian of a * b w.r.t. b is the identity, so d(a Exp(tau))/d tau is Jr
// itself.
template <class Group, class Tangent, class Jacobian>
Group retract(const Group& a, const Tangent& tau, Jacobian* J_x_a, Jacobian* J_x_tau) noexcept {
  return a.compose(Group::exp(tau, J_x_tau), J_x_a, nullptr);
}

// Log(a^-1 b), with Jr^-1 of that difference chained onto between's Jacobians.
template <class Group, class Jacobian>
auto localCoordinates(const Group& a, const Group& b, Jacobian* J_t_a, Jacobian* J_t_b) noexcept {
  Jacobian J_d_a;
  Jacobian J_r_inv;
  const bool want_jacobian = J_t_a != nullptr || J_t_b != nullptr;
  const Group d = a.between(b, J_t_a != nullptr ? &J_d_a : nullptr, nullptr);
  const auto tau = d.log(want_jacobian ? &J_r_inv : nullptr);
  if (J_t_a != nullptr) *J_t_a = J_r_inv * J_d_a;
  if (J_t_b != nullptr) *J_t_b = J_r_inv;  // the Jacobian of between w.r.t. b is the identity
  return tau;
}

}  // namespace lslam::detail
