#pragma once
// A parameter set's check as a table of its fields (the IsValid of the car and damper
// parameters): each field's name, its value, and whether the value is in its range.
#include <cmath>
#include <initializer_list>

namespace mrd::sim_internal {

struct ParamField {
  const char* name;
  double value;  // must be finite
  bool ok;       // the field's own range check
};

// True when every field is finite and in its range; else false, with *reason (when given)
// the first failing field's name.
inline bool FieldsValid(std::initializer_list<ParamField> fields, const char** reason) {
  for (const ParamField& f : fields) {
    if (!std::isfinite(f.value) || !f.ok) {
      if (reason != nullptr) *reason = f.name;
      return false;
    }
  }
  return true;
}

}  // namespace mrd::sim_internal
