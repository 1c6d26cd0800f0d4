#pragma once
// One coefficient table's model, read-only once loaded, shared by every channel (controller:
// its model runtime and its inverter) that runs the table: several channels on one table hold
// one copy of the model instead of one each. What changes per period (the regressor history,
// the envelope, the command range) stays in each channel's runtime and inverter.
//
// Scalar type T (real.hpp): the table's double model rounded to T at load.

#include <memory>

#include "mrd/common/model.hpp"
#include "mrd/common/result.hpp"
#include "mrd/common/table.hpp"
#include "mrd/firmware/real.hpp"

namespace mrd::firmware {

template <class T>
class BasicSharedModel {
 public:
  // The table (a copy) and its model in T; nullptr with *error set (the table's Validate error,
  // or kNonFinite for a number of the model beyond T) on a refusal. Not real-time (start-up).
  static std::shared_ptr<const BasicSharedModel> Load(const CoefficientTable& table, Error* error);

  const CoefficientTable& table() const { return table_; }
  const BasicModel<T>& model() const { return model_; }

 private:
  CoefficientTable table_;
  BasicModel<T> model_;
};

using SharedModel = BasicSharedModel<Real>;

}  // namespace mrd::firmware
