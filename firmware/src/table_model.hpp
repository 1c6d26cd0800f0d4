#pragma once
// The start of configuring from a coefficient table, shared by the model runtime's and the
// inverter's Configure: the table checked, its model rounded to T and checked again.
#include "mrd/common/model.hpp"
#include "mrd/common/result.hpp"
#include "mrd/common/table.hpp"

namespace mrd::firmware {

// kOk with *model the table's model in T; else the table's error (CoefficientTable::Validate)
// or the rounded model's (a number beyond T's range).
template <class T>
Error TableModelAs(const CoefficientTable& table, BasicModel<T>* model) {
  const Error e = table.Validate();
  if (e != Error::kOk) return e;
  *model = ModelAs<T>(table.model);
  return model->Validate();
}

}  // namespace mrd::firmware
