#pragma once
// Forward sensitivities of mrd fit-spencer's simulator: the residual (simulated - measured
// force [N]) at every sample of a run and its exact derivative with respect to the Spencer
// parameters, by propagating d(y, z, u)/dp through every RK4 stage alongside the state (the
// tangent of the discrete map SpencerDamper::Step computes, so the derivative of exactly the
// residual the fit minimises). One pass costs a few simulations instead of the 14 extra ones a
// forward-difference Jacobian needs. The state is simulated as SimResidual (spencer_fit.cpp):
// at rest at the first row, u = 0 V, measured E of the interval's end clamped to [0, e_max].
//
// Corner cases: d/dz of |z|^n at z = 0 is 0 for n >= 1 (the fit's bounds), and d/dn of it is
// taken as 0 there (z |z|^(n-1) ln|z| -> 0); d|dv|/d dv at dv = 0 is taken as 0.

#include "mrd/host/spencer_fit.hpp"

namespace mrd::host {

constexpr int kSpencerParamCount = 14;  // params::SpencerFields order

// p: the 14 parameters (params::SpencerFields order, spencer_damper.hpp units).
// residual (rows = run.x.size()) gets f^ - f; jac (row-major, row stride `stride`) gets
// column j = d residual / d p_j * col_scale[j] for j in [j0, j1) (other columns untouched).
// Either output may be nullptr. Returns false when the force turned non-finite or above 1e9 N
// (the outputs then hold what was computed), as SimResidual does.
bool SpencerSensitivity(const double* p, const FitRun& run, int substeps, double e_max, int j0,
                        int j1, const double* col_scale, double* residual, double* jac, int stride);

}  // namespace mrd::host
