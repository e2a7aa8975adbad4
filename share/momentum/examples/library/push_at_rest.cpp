// The generalized-momentum observer on a robot profile, from C++: the arm is held still at
// q = 0.5 rad while someone pushes joint 2 along its axis with 5 Nm, so the motors hold
// g(q) - 5 Nm there. The observer's disturbance (dp/dt = tau_m - beta - tau_d, see
// mo-observe(1)) is then tau_d = -5 Nm, and the first-order residual follows it as
// r = -5 (1 - exp(-K1 t)); with K1 = 50 1/s it is within 0.1% of it after 0.14 s.
//   push-at-rest PROFILE       (e.g. share/momentum/robots/paper-arm/paper-arm.json)
#include <cstdio>
#include <exception>
#include <vector>

#include <momentum/model/dynamics.hpp>
#include <momentum/model/model.hpp>
#include <momentum/model/profile.hpp>
#include <momentum/observer/observer.hpp>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: push-at-rest PROFILE\n");
    return 2;
  }
  try {
    namespace mm = momentum::model;
    const mm::Profile profile = mm::load_profile(argv[1]);
    const mm::Model model = mm::build_model(profile);
    mm::Data data(model);
    const Eigen::VectorXd q = Eigen::VectorXd::Constant(model.nq, 0.5);
    const Eigen::VectorXd dq = Eigen::VectorXd::Zero(model.nq);
    Eigen::VectorXd g;
    mm::gravity_torque(model, data, q, g);

    momentum::observer::ObserverOptions options;  // first order, K1 = 50 1/s
    momentum::observer::MomentumObserver observer(model, options, /*friction=*/nullptr);
    const double push = 5.0, dt = 0.001;
    Eigen::VectorXd tau_m = g, r(model.nq), tau_f(model.nq), mu(model.nq);
    tau_m[1] -= push;
    for (int k = 0; k <= 500; ++k) {
      observer.step(k * dt, q.data(), dq.data(), tau_m.data(), r.data(), tau_f.data(), mu.data());
      if (k == 20 || k == 500)
        std::printf("t=%.3f s r1=%.4f r2=%.4f Nm\n", k * dt, r[0], r[1]);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "push-at-rest: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
