#pragma once
// Polynomial NARX model with non-polynomial elementary regressors (docs/design.md §4), in a
// fixed-size form shared by host simulation, the coefficient table and the firmware.
//
//   y(k) = sum_i theta_i * prod_j r_{a_ij}(k - d_ij)^{p_ij}
//
// where each elementary regressor r_a(k) = T_a(s_c(k)) is a transform T_a of one normalised
// channel s_c (identity, |s|^e, sign(s), tanh(s/a), clamp(s,-c,c)) or a first-order low-pass of an
// input channel (noisy or lagging command signals of real rigs). The output channel enters only at
// delays >= 1 and only through memoryless transforms.
// Normalisation: s = (raw - offset) / scale per channel; the output is denormalised the
// same way.
//
// Scalar type: the model and its evaluation are templates on the real type T (double or
// float; both instantiated in model.cpp). Host code, the table and its file use T = double
// (Model, RegressorHistory, ModelRunner, ...); a float copy of a model (ModelAs<float>) runs
// the firmware's float build (MRD_REAL=float, firmware/include/mrd/firmware/real.hpp).

#include <array>
#include <cstdint>
#include <span>
#include <type_traits>

#include "mrd/common/result.hpp"

namespace mrd {

inline constexpr std::size_t kMaxChannels = 8;     // signals a model may read (incl. output)
inline constexpr std::size_t kMaxRegressors = 16;  // elementary regressors
inline constexpr std::size_t kMaxDelay = 15;       // largest delay [samples]
inline constexpr std::size_t kMaxFactors = 4;      // factors per term
inline constexpr std::size_t kMaxTerms = 64;       // terms per model
inline constexpr std::uint8_t kMaxPower = 16;      // largest power of one factor
inline constexpr std::size_t kMaxNameLength = 15;  // channel name, NUL-terminated in 16 bytes

// Elementary transform of a normalised channel value s.
enum class Transform : std::uint8_t {
  kIdentity = 0,  // s
  kAbsPow = 1,    // |s|^exponent (exponent > 0; 0 at s == 0)
  kSign = 2,      // sign(s) in {-1, 0, 1}
  // r(k) = a r(k-1) + (1 - a) s(k), a = exp(-1/tau), tau = exponent [samples] in
  // (0, kMaxLowPassTau]; r(-1) = 0 after a reset. Input channels only. Unit DC gain.
  kLowPass = 3,
  // Saturating transforms (flat extrapolation beyond the data, e.g. force vs velocity):
  kTanh = 4,  // tanh(s / exponent), exponent = scale > 0 [normalised units]
  kClip = 5,  // clamp(s, -exponent, exponent), exponent = limit c > 0 [normalised units]
};
inline constexpr Transform kLastTransform = Transform::kClip;
inline constexpr double kMaxLowPassTau = 1.0e6;  // [samples]

// T(s) for one memoryless elementary regressor (kLowPass: s, its input). Real-time safe.
template <class T>
T ApplyTransform(Transform t, T exponent, std::type_identity_t<T> s);
// Pole a = exp(-1/tau) of the kLowPass transform, tau [samples] > 0 (computed in double).
double LowPassPole(double tau);
// One kLowPass update: r(k) = a r(k-1) + (1 - a) s(k), pole a. The one definition used by the
// history, the host's whole-record columns and (as alpha + beta s) the inverter.
template <class T>
inline T LowPassStep(T pole, std::type_identity_t<T> previous, std::type_identity_t<T> s) {
  return pole * previous + (T(1) - pole) * s;
}

template <class T>
struct BasicRegressor {
  std::uint8_t channel = 0;
  Transform transform = Transform::kIdentity;
  T exponent = T(1);  // kAbsPow: the exponent; kLowPass: tau [samples]; kTanh: scale;
                      // kClip: limit; else unused
};
using Regressor = BasicRegressor<double>;

struct Factor {
  std::uint8_t regressor = 0;  // index into Model::regressors
  std::uint8_t delay = 0;      // [samples]
  std::uint8_t power = 1;      // 1 ... kMaxPower
};

struct Term {
  std::array<Factor, kMaxFactors> factors{};
  std::uint8_t num_factors = 0;  // 0: the constant term

  std::span<const Factor> active() const { return {factors.data(), num_factors}; }
};

template <class T>
struct BasicChannelScale {
  T offset = T(0);
  T scale = T(1);  // > 0
};
using ChannelScale = BasicChannelScale<double>;

template <class T>
struct BasicModel {
  std::uint8_t num_channels = 0;
  std::uint8_t output_channel = 0;
  std::array<std::array<char, kMaxNameLength + 1>, kMaxChannels> channel_names{};
  std::array<BasicChannelScale<T>, kMaxChannels> scales{};
  std::uint8_t num_regressors = 0;
  std::array<BasicRegressor<T>, kMaxRegressors> regressors{};
  std::uint8_t num_terms = 0;
  std::array<Term, kMaxTerms> terms{};
  std::array<T, kMaxTerms> coefficients{};

  // Checks counts against capacities, indices, delays (output at >= 1), powers, finite
  // positive scales and exponents, finite coefficients, NUL-terminated names.
  // Returns kOk or the first problem (kCapacityExceeded, kOutOfRange, kNonFinite,
  // kInvalidArgument).
  Error Validate() const;
  // Largest delay used by any factor [samples].
  std::uint8_t MaxDelay() const;
  // Channel index by name, or -1. Not for the real-time path (string compare).
  int ChannelIndex(const char* name) const;
};
using Model = BasicModel<double>;

// The model with every number (scales, exponents, coefficients) rounded to nearest T: the
// firmware's float build converts the table's double model once, at configuration. A number
// beyond T's range becomes infinite, which Validate() of the result reports (kNonFinite).
template <class T>
BasicModel<T> ModelAs(const Model& model);

// Delayed values of every elementary regressor of one model: value(r, d) = r(k - d).
// Fixed size; no allocation.
template <class T>
class BasicRegressorHistory {
 public:
  // Clears all values to T(0) and caches the model's low-pass poles (start-up cost, not per
  // sample). Call before the first PushInputs and whenever the model changes.
  void Reset(const BasicModel<T>& model);
  // Starts sample k: shifts by one and stores the delay-0 values of the regressors of every
  // channel except the output, from normalised channel values s[c] (size >= num_channels;
  // s[output_channel] is ignored). Low-pass regressors advance their filter by one sample.
  void PushInputs(const BasicModel<T>& model, std::span<const T> normalised);
  // Every delay of every regressor at its steady state for constant normalised channel values
  // s[c] (size >= num_channels, the output's included; low-pass regressors at s itself), as if
  // the channels had held them forever. A state to evaluate the model in (host checks over a
  // grid); PushInputs then starts the next sample. Real-time safe.
  void Hold(const BasicModel<T>& model, std::span<const T> normalised);
  // Completes sample k with the output's normalised value (after evaluation).
  void SetOutput(const BasicModel<T>& model, T y_normalised);
  // Replaces the delay-0 values of the regressors of one input channel (not the output) of
  // sample k, e.g. once the inverter has chosen the command. Real-time safe.
  void SetInput(const BasicModel<T>& model, std::size_t channel, T normalised);
  T value(std::size_t regressor, std::size_t delay) const {
    return values_[regressor][(head_ + delay) % kDepth];
  }
  // Pole of a kLowPass regressor (LowPassPole(tau)); 0 for every other transform.
  T low_pass_pole(std::size_t regressor) const { return pole_[regressor]; }

 private:
  static constexpr std::size_t kDepth = kMaxDelay + 1;
  T Transformed(const BasicRegressor<T>& reg, std::size_t r, T s) const;

  std::array<std::array<T, kDepth>, kMaxRegressors> values_{};
  std::array<T, kMaxRegressors> pole_{};  // low-pass poles (Reset)
  std::size_t head_ = 0;                  // slot of delay 0
};
using RegressorHistory = BasicRegressorHistory<double>;

// prod_j value(factor_j)^power_j for one term; 1 for the constant term. Real-time safe.
template <class T>
T TermValue(const Term& term, const BasicRegressorHistory<T>& h);

// Normalised model output for the current sample: sum_i theta_i * TermValue(term_i).
template <class T>
T EvaluateNormalised(const BasicModel<T>& model, const BasicRegressorHistory<T>& h);

template <class T>
inline T Normalise(const BasicChannelScale<T>& s, std::type_identity_t<T> raw) {
  return (raw - s.offset) / s.scale;
}
template <class T>
inline T Denormalise(const BasicChannelScale<T>& s, std::type_identity_t<T> n) {
  return n * s.scale + s.offset;
}

// Free-run (simulation) runner: feeds raw inputs sample by sample, feeds back its own
// output. Fixed size, real-time safe after construction. Host `mrd simulate` and the firmware
// runtime both step through this class, so they compute the same numbers.
template <class T>
class BasicModelRunner {
 public:
  explicit BasicModelRunner(const BasicModel<T>& model) : model_(&model) { Reset(); }
  // Zero history (all channels at normalised 0).
  void Reset();
  // Seeds one past sample (raw channel values, including the output) into the history, as
  // when a simulation starts from measured initial conditions.
  void Seed(std::span<const T> raw);
  // One sample: raw channel values (output slot ignored) -> raw output estimate. The output
  // is fed back for the next sample.
  T Step(std::span<const T> raw);
  const BasicRegressorHistory<T>& history() const { return history_; }
  const BasicModel<T>& model() const { return *model_; }
  // Prepares sample k without evaluating (used by the inverter to evaluate with a candidate
  // input); Finish completes it with the raw output actually obtained.
  void Begin(std::span<const T> raw);
  void Finish(T y_raw);
  // Between Begin and Finish: replaces one input channel's raw value of the current sample
  // (the output channel is ignored). Begin(raw) then SetInput(c, u) computes exactly what
  // Begin(raw with raw[c] = u) computes. Real-time safe.
  void SetInput(std::size_t channel, T raw);
  // Between Begin and Finish: raw model output for the current sample. Step(raw) is
  // Begin(raw); y = Evaluate(); Finish(y). Real-time safe.
  T Evaluate() const;

 private:
  const BasicModel<T>* model_;
  BasicRegressorHistory<T> history_;
  std::array<T, kMaxChannels> normalised_{};
};
using ModelRunner = BasicModelRunner<double>;

}  // namespace mrd
