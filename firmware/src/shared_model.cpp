#include "mrd/firmware/shared_model.hpp"

#include "table_model.hpp"

namespace mrd::firmware {

template <class T>
std::shared_ptr<const BasicSharedModel<T>> BasicSharedModel<T>::Load(const CoefficientTable& table,
                                                                     Error* error) {
  auto shared = std::make_shared<BasicSharedModel<T>>();
  *error = TableModelAs(table, &shared->model_);
  if (*error != Error::kOk) return nullptr;
  shared->table_ = table;
  return shared;
}

template class BasicSharedModel<double>;
template class BasicSharedModel<float>;

}  // namespace mrd::firmware
