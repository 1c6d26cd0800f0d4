#pragma once
// Model runtime: one identified model (from a coefficient table) run in free-run mode, one
// sample per control period, on common's ModelRunner (the evaluator host simulation uses).
//
//   f(k) = model(v(k), x(k), E(k), history)   [N]; f(k) is fed back as the output history.
//
// Channels are bound by name at configuration: the table's input channel is the command E,
// the output channel is the force, "v" is the velocity [cm/s], "x" the displacement [cm].
//
// Scalar type T (real.hpp): the table's double model is rounded to T at Configure; the step
// runs in T. ModelRuntime is the firmware's (T = Real).
//
// Operating envelope (table version 2, SetEnvelope): v and x are held to
// [min - m, max + m], m = margin * (max - min), of the identification data before the model
// sees them, and the force fed back as output history is held to the force envelope the same
// way, so the model is evaluated only at its data's edge outside it: bounded, finite. Each
// sample with a held input (velocity or displacement) counts one input excursion; each held
// force one force excursion. The command E is not held (the inverter keeps it in
// [e_min, e_max]).

#include <array>
#include <cstdint>
#include <memory>

#include "mrd/common/model.hpp"
#include "mrd/common/result.hpp"
#include "mrd/common/table.hpp"
#include "mrd/firmware/real.hpp"
#include "mrd/firmware/shared_model.hpp"

namespace mrd::firmware {

template <class T>
class BasicModelRuntime {
 public:
  BasicModelRuntime();
  BasicModelRuntime(const BasicModelRuntime&) = delete;
  BasicModelRuntime& operator=(const BasicModelRuntime&) = delete;

  // Copies and binds a validated table (a shared model of its own). kInvalidArgument when the
  // model reads a channel the firmware does not provide (not v, x, the input or the output);
  // table.Validate() errors; kNonFinite when a number of the model overflows T. Not real-time
  // (start-up).
  Error Configure(const CoefficientTable& table);
  // Binds a loaded model shared with other runtimes (shared_model.hpp; non-null): the history
  // is this runtime's. kInvalidArgument as above. Not real-time (start-up).
  Error Configure(std::shared_ptr<const BasicSharedModel<T>> shared);
  // Uses the table's envelope with margin (fraction of each channel's range, >= 0) when use is
  // true and the table has one; otherwise evaluates the inputs as they are. kOutOfRange for a
  // negative or non-finite margin. The excursion counters are kept (ClearExcursions). Real-time
  // safe (a retune at a period boundary).
  Error SetEnvelope(bool use, double margin);
  // Clears the history (all channels at normalised 0). Real-time safe.
  void Reset() { runner_.Reset(); }
  // Starts sample k with velocity v [cm/s] and displacement x [cm] (x ignored when the model
  // does not read it); the command slot is provisional until ForceAt/Finish. Real-time safe.
  void Begin(T v, T x);
  // Model force [N] of the current sample if the command were E [V]. Real-time safe.
  T ForceAt(T E);
  // Completes the current sample with the command actually sent E [V]; returns its force [N]
  // (held to the force envelope when it is active), which becomes the output history.
  // Real-time safe.
  T Finish(T E);
  // Pushes one measured sample (v [cm/s], x [cm], E [V], force f [N]) into the history without
  // evaluating, e.g. to start from measured initial conditions as `mrd simulate` does.
  // Real-time safe.
  void Seed(T v, T x, T E, T f);
  // Begin + Finish. Real-time safe.
  T Step(T v, T x, T E) {
    Begin(v, x);
    return Finish(E);
  }

  const BasicRegressorHistory<T>& history() const { return runner_.history(); }
  const CoefficientTable& table() const { return shared_->table(); }
  const BasicModel<T>& model() const { return shared_->model(); }
  // The model data bound (shared with the channels on the same table).
  const std::shared_ptr<const BasicSharedModel<T>>& shared() const { return shared_; }
  bool reads_displacement() const { return x_channel_ >= 0; }
  bool reads_velocity() const { return v_channel_ >= 0; }
  bool envelope_active() const { return envelope_; }
  // v [cm/s] and x [cm] of the current (last begun) sample as the model got them: held to the
  // envelope when it is active (x as given when the model does not read it).
  T held_v() const { return held_v_; }
  T held_x() const { return held_x_; }
  std::uint64_t input_excursions() const { return input_excursions_; }
  std::uint64_t force_excursions() const { return force_excursions_; }
  void ClearExcursions() {
    input_excursions_ = 0;
    force_excursions_ = 0;
  }

 private:
  std::shared_ptr<const BasicSharedModel<T>> shared_;  // never null (empty before Configure)
  BasicModelRunner<T> runner_;                         // on shared_->model()
  std::size_t input_channel_ = 0;                      // shared_->table()'s, at hand
  std::size_t output_channel_ = 0;
  std::array<T, kMaxChannels> raw_{};
  int v_channel_ = -1;
  int x_channel_ = -1;
  bool envelope_ = false;
  std::array<T, kMaxChannels> lo_{};  // envelope with margin [raw units]
  std::array<T, kMaxChannels> hi_{};
  std::uint64_t input_excursions_ = 0;
  std::uint64_t force_excursions_ = 0;
  T held_v_ = T(0);
  T held_x_ = T(0);
};

using ModelRuntime = BasicModelRuntime<Real>;

}  // namespace mrd::firmware
