#pragma once
// Model runtime: one identified model (from a coefficient table) run in free-run mode, one
// sample per control period, on common's ModelRunner (the evaluator host simulation uses).
//
//   f(k) = model(v(k), x(k), E(k), history)   [N]; f(k) is fed back as the output history.
//
// Channels are bound by name at configuration: the table's input channel is the command E,
// the output channel is the force, "v" is the velocity [cm/s], "x" the displacement [cm].

#include <array>
#include <cstdint>

#include "mrd/common/model.hpp"
#include "mrd/common/result.hpp"
#include "mrd/common/table.hpp"

namespace mrd::firmware {

class ModelRuntime {
 public:
  ModelRuntime() : runner_(table_.model) {}
  ModelRuntime(const ModelRuntime&) = delete;  // runner_ points into table_
  ModelRuntime& operator=(const ModelRuntime&) = delete;

  // Copies and binds a validated table. kInvalidArgument when the model reads a channel the
  // firmware does not provide (not v, x, the input or the output); table.Validate() errors.
  // Not real-time (start-up).
  Error Configure(const CoefficientTable& table);
  // Clears the history (all channels at normalised 0). Real-time safe.
  void Reset() { runner_.Reset(); }
  // Starts sample k with velocity v [cm/s] and displacement x [cm] (x ignored when the model
  // does not read it); the command slot is provisional until ForceAt/Finish. Real-time safe.
  void Begin(double v, double x);
  // Model force [N] of the current sample if the command were E [V]. Real-time safe.
  double ForceAt(double E);
  // Completes the current sample with the command actually sent E [V]; returns its force [N],
  // which becomes the output history. Real-time safe.
  double Finish(double E);
  // Pushes one measured sample (v [cm/s], x [cm], E [V], force f [N]) into the history without
  // evaluating, e.g. to start from measured initial conditions as `mrd simulate` does.
  // Real-time safe.
  void Seed(double v, double x, double E, double f);
  // Begin + Finish. Real-time safe.
  double Step(double v, double x, double E) {
    Begin(v, x);
    return Finish(E);
  }

  const RegressorHistory& history() const { return runner_.history(); }
  const CoefficientTable& table() const { return table_; }
  bool reads_displacement() const { return x_channel_ >= 0; }
  bool reads_velocity() const { return v_channel_ >= 0; }

 private:
  CoefficientTable table_;
  ModelRunner runner_;
  std::array<double, kMaxChannels> raw_{};
  int v_channel_ = -1;
  int x_channel_ = -1;
};

}  // namespace mrd::firmware
