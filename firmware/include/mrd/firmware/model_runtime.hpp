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

#include <array>
#include <cstdint>

#include "mrd/common/model.hpp"
#include "mrd/common/result.hpp"
#include "mrd/common/table.hpp"
#include "mrd/firmware/real.hpp"

namespace mrd::firmware {

template <class T>
class BasicModelRuntime {
 public:
  BasicModelRuntime() : runner_(model_) {}
  BasicModelRuntime(const BasicModelRuntime&) = delete;  // runner_ points into model_
  BasicModelRuntime& operator=(const BasicModelRuntime&) = delete;

  // Copies and binds a validated table. kInvalidArgument when the model reads a channel the
  // firmware does not provide (not v, x, the input or the output); table.Validate() errors;
  // kNonFinite when a number of the model overflows T. Not real-time (start-up).
  Error Configure(const CoefficientTable& table);
  // Clears the history (all channels at normalised 0). Real-time safe.
  void Reset() { runner_.Reset(); }
  // Starts sample k with velocity v [cm/s] and displacement x [cm] (x ignored when the model
  // does not read it); the command slot is provisional until ForceAt/Finish. Real-time safe.
  void Begin(T v, T x);
  // Model force [N] of the current sample if the command were E [V]. Real-time safe.
  T ForceAt(T E);
  // Completes the current sample with the command actually sent E [V]; returns its force [N],
  // which becomes the output history. Real-time safe.
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
  const CoefficientTable& table() const { return table_; }
  const BasicModel<T>& model() const { return model_; }
  bool reads_displacement() const { return x_channel_ >= 0; }
  bool reads_velocity() const { return v_channel_ >= 0; }

 private:
  CoefficientTable table_;
  BasicModel<T> model_;  // table_.model in T
  BasicModelRunner<T> runner_;
  std::array<T, kMaxChannels> raw_{};
  int v_channel_ = -1;
  int x_channel_ = -1;
};

using ModelRuntime = BasicModelRuntime<Real>;

}  // namespace mrd::firmware
