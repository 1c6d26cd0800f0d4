#include "mrd/structure/design.hpp"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <unsupported/Eigen/MatrixFunctions>

namespace mrd::structure {

namespace {

using Mat = Eigen::MatrixXd;
constexpr int kN = ShearFrameParams::kFloors;

struct Continuous {
  Mat A, B, G, Cy, Dy;  // x' = A x + B f + G ag ; xa = Cy x + Dy f
};

Continuous Model(const ShearFrameParams& p) {
  Mat M = Mat::Zero(kN, kN), K(kN, kN), C(kN, kN);
  for (int i = 0; i < kN; ++i) {
    M(i, i) = p.mass_kg[i];
    for (int j = 0; j < kN; ++j) {
      K(i, j) = p.stiffness[i * kN + j];
      C(i, j) = p.damping[i * kN + j];
    }
  }
  const Mat Minv = M.inverse();
  // One column per damper: -1 on the floor above its story, +1 on the floor below.
  const int dampers = p.with_damper ? p.dampers : 0;
  Mat gamma = Mat::Zero(kN, dampers);
  for (int j = 0; j < dampers; ++j) {
    const int upper = p.story[j] - 1;
    gamma(upper, j) = -1.0;
    if (upper > 0) gamma(upper - 1, j) = 1.0;
  }
  Continuous m;
  m.A = Mat::Zero(2 * kN, 2 * kN);
  m.A.block(0, kN, kN, kN) = Mat::Identity(kN, kN);
  m.A.block(kN, 0, kN, kN) = -Minv * K;
  m.A.block(kN, kN, kN, kN) = -Minv * C;
  m.B = Mat::Zero(2 * kN, dampers);
  m.B.block(kN, 0, kN, dampers) = Minv * gamma;
  m.G = Mat::Zero(2 * kN, 1);
  m.G.block(kN, 0, kN, 1) = -Mat::Ones(kN, 1);
  m.Cy = Mat(kN, 2 * kN);
  m.Cy << -Minv * K, -Minv * C;
  m.Dy = Minv * gamma;
  return m;
}

// Discrete algebraic Riccati equation by fixed-point iteration:
// P = Q + A'PA - A'PB (R + B'PB)^-1 B'PA. Returns false when not converged.
bool SolveDare(const Mat& A, const Mat& B, const Mat& Q, const Mat& R, Mat* P) {
  Mat X = Q;
  for (int it = 0; it < 2000000; ++it) {
    const Mat S = R + B.transpose() * X * B;
    const Mat next =
        Q + A.transpose() * X * A - A.transpose() * X * B * S.ldlt().solve(B.transpose() * X * A);
    const double change = (next - X).norm();
    X = 0.5 * (next + next.transpose());
    if (!std::isfinite(change)) return false;
    if (change <= 1e-12 * (1.0 + X.norm())) {
      *P = X;
      return true;
    }
  }
  return false;
}

template <int N>
void Store(const Mat& m, double (&out)[N]) {
  int k = 0;
  for (int r = 0; r < m.rows(); ++r) {
    for (int c = 0; c < m.cols(); ++c) out[k++] = m(r, c);
  }
}

}  // namespace

Modes FrameModes(const ShearFrameParams& frame) {
  const Continuous m = Model(frame);
  Eigen::EigenSolver<Mat> es(m.A);
  std::array<std::complex<double>, 3> poles{};
  int n = 0;
  for (int i = 0; i < es.eigenvalues().size() && n < 3; ++i) {
    if (es.eigenvalues()(i).imag() > 0.0)
      poles[static_cast<std::size_t>(n++)] = es.eigenvalues()(i);
  }
  std::sort(poles.begin(), poles.begin() + n,
            [](auto a, auto b) { return std::abs(a) < std::abs(b); });
  Modes modes;
  for (std::size_t i = 0; i < 3; ++i) {
    const double wn = std::abs(poles[i]);
    modes.frequency_hz[i] = wn / (2.0 * M_PI);
    modes.damping_ratio[i] = wn > 0.0 ? -poles[i].real() / wn : 0.0;
  }
  return modes;
}

bool DesignClippedOptimal(const ShearFrameParams& frame, const DesignOptions& o,
                          firmware::ClippedOptimalGains* gains, std::string* error) {
  if (!(o.period_s > 0.0) || !(o.r_force > 0.0) || !(o.q_displacement >= 0.0) ||
      !(o.q_drift >= 0.0) || !(o.q_displacement + o.q_drift > 0.0) || !(o.noise_ratio > 0.0) ||
      !std::isfinite(o.v_max)) {
    *error =
        "design: period, r_force, noise_ratio must be > 0; q_displacement, q_drift >= 0 "
        "and not both 0";
    return false;
  }
  const char* reason = nullptr;
  if (!frame.with_damper || !frame.IsValid(&reason) ||
      frame.dampers > firmware::ClippedOptimalGains::kMaxDampers) {
    *error = std::string("design: the frame needs 1 to ") +
             std::to_string(firmware::ClippedOptimalGains::kMaxDampers) +
             " dampers at distinct stories (" + (reason != nullptr ? reason : "with_damper") + ")";
    return false;
  }
  const Continuous m = Model(frame);
  const int n = 2 * kN;
  const int nd = frame.dampers;
  // Zero-order-hold discretisation of (A, [B G]) by the augmented matrix exponential.
  Mat aug = Mat::Zero(n + nd + 1, n + nd + 1);
  aug.block(0, 0, n, n) = m.A;
  aug.block(0, n, n, nd) = m.B;
  aug.block(0, n + nd, n, 1) = m.G;
  const Mat e = (aug * o.period_s).exp();
  const Mat Ad = e.block(0, 0, n, n);
  const Mat Bd = e.block(0, n, n, nd);
  const Mat Gd = e.block(0, n + nd, n, 1);

  // LQR: weights on floor displacements and drifts (x_i - x_{i-1}, x_0 = ground).
  Mat Q = Mat::Zero(n, n);
  Mat drift = Mat::Zero(kN, n);
  for (int i = 0; i < kN; ++i) {
    drift(i, i) = 1.0;
    if (i > 0) drift(i, i - 1) = -1.0;
  }
  Q.block(0, 0, kN, kN) = o.q_displacement * Mat::Identity(kN, kN);
  Q += o.q_drift * drift.transpose() * drift;
  const Mat R = o.r_force * Mat::Identity(nd, nd);
  Mat P;
  if (!SolveDare(Ad, Bd, Q, R, &P)) {
    *error = "design: the LQR Riccati iteration did not converge";
    return false;
  }
  const Mat K = (R + Bd.transpose() * P * Bd).ldlt().solve(Bd.transpose() * P * Ad);

  // Kalman predictor: ground acceleration of unit PSD, measurement noise of PSD 1/gamma_g,
  // each as the discrete covariance of a white sequence sampled at T.
  const Mat W = Gd * Gd.transpose() / o.period_s;
  const Mat V = Mat::Identity(kN, kN) * (1.0 / o.noise_ratio) / o.period_s;
  Mat S;
  if (!SolveDare(Ad.transpose(), m.Cy.transpose(), W, V, &S)) {
    *error = "design: the Kalman Riccati iteration did not converge";
    return false;
  }
  const Mat L = Ad * S * m.Cy.transpose() * (m.Cy * S * m.Cy.transpose() + V).inverse();

  gains->dampers = nd;
  Store(Ad, gains->ad);
  Store(Bd, gains->bd);
  Store(m.Cy, gains->cy);
  Store(m.Dy, gains->dy);
  Store(L, gains->l);
  Store(K, gains->k);
  gains->v_max = o.v_max;
  gains->v_min = 0.0;
  return true;
}

std::string GainsToml(const firmware::ClippedOptimalGains& g, const DesignOptions& o) {
  std::ostringstream out;
  out.precision(17);
  out << "# Clipped-optimal gains (mrd-structure design): period " << o.period_s
      << " s, q_displacement " << o.q_displacement << ", q_drift " << o.q_drift << ", r_force "
      << o.r_force << ", noise_ratio " << o.noise_ratio << "\n";
  out << "[control.clipped_optimal]\n";
  const auto array = [&](const char* name, const double* v, int count) {
    out << name << " = [";
    for (int i = 0; i < count; ++i) out << (i ? ", " : "") << v[i];
    out << "]\n";
  };
  constexpr int ns = firmware::ClippedOptimalGains::kStates;
  constexpr int no = firmware::ClippedOptimalGains::kOutputs;
  const int m = g.dampers;
  if (m != 1) out << "dampers = " << m << "\n";  // one damper: the key's default, left out
  array("ad", g.ad, ns * ns);
  array("bd", g.bd, ns * m);
  array("cy", g.cy, no * ns);
  array("dy", g.dy, no * m);
  array("l", g.l, ns * no);
  array("k", g.k, m * ns);
  out << "v_max = " << g.v_max << "\nv_min = " << g.v_min << "\n";
  return out.str();
}

}  // namespace mrd::structure
