#pragma once
// Scalar type of the firmware's per-sample computation: model step, inversion, velocity
// filter and control law. double by default; float with the CMake option MRD_REAL=float (for
// boards without fast double precision), which defines MRD_REAL_FLOAT for every user of
// mrd::firmware. The coefficient table, the configuration and the I/O frames stay double: the
// model is rounded to Real once at configuration (mrd::ModelAs), sensor values at the entry of
// Controller::Update, and its outputs go back to double.
//
// ModelRuntime and Inverter are class templates on the scalar type, both instantiated, so the
// float code path can be compared with the double one in one program (the float accuracy test).

namespace mrd::firmware {

#if defined(MRD_REAL_FLOAT)
using Real = float;
#else
using Real = double;
#endif

}  // namespace mrd::firmware
