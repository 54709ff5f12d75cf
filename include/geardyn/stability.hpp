// geardyn: Floquet stability of the motion in permanent contact, pipeline stage 6 beside
// orbit.hpp: the Mathieu-Hill problem of the mesh stiffness harmonics.
//
// In permanent drive-side contact the gear model is a linear system with periodic
// coefficients, y' = A(t) y + u(t), A of period T_k (the mesh period; the system period when
// the stiffness is constant). Its response is stable when every Floquet multiplier, an
// eigenvalue of the monodromy Phi(T_k) (the exact engine's, the contact region's guards
// removed), lies inside the unit circle (or on it, to within 1e-9: neutral, as the undamped
// system's are). Along a case key the multipliers are sampled; where
// det(Phi - I) or det(Phi + I) changes sign between two samples (a real multiplier through
// +1 or -1) or a complex pair crosses the unit circle, the boundary is located by TOMS 748 on
// that test function to kBoundaryWidth of the key's range.
#pragma once

#include <complex>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "geardyn/case.hpp"
#include "geardyn/continuation.hpp"
#include "geardyn/stiffness.hpp"
#include "geardyn/sweep.hpp"

namespace geardyn {

// A located boundary's width in the key, relative to |to - from|.
constexpr double kBoundaryWidth = 1e-13;

// The monodromy of the motion in permanent drive-side contact, over `period_s` (0: the
// stiffness period, or the system period when the stiffness is constant), by the exact engine
// at `tolerance`; `stiffness`, when given, is the case's mesh stiffness (shared_stiffness: a
// study computes it once). A gear train's has every mesh in drive contact over the meshes'
// common period and is read in its own coordinates (train::Assembled::reduced_basis: the free
// bodies' with a prescribed speed, else modulo the rigid rotation). Throws InputError when the
// case has no period.
ode::Matrix contact_monodromy(const Case& c, double tolerance = 1e-12, double period_s = 0,
                              const MeshStiffness* stiffness = nullptr);

// The same without the multipliers every freely turning train has whatever its meshes do: the
// rate of each rigid motion that nothing damps maps to itself (a multiplier of exactly 1, whose
// det(M - I) rounding leaves of either sign). Where nothing grounds the motions the flow is
// read on their mass-orthogonal complement, which every K(t) and C(t) keep (2 k states fewer:
// the pair's train has the one-degree model's two); where a drag damps them, as contact_monodromy
// with each kept rate deflated. The other multipliers, which the stability study reads (its
// boundaries would otherwise be rounding's). The same matrix as contact_monodromy where there
// is no such rate.
ode::Matrix elastic_contact_monodromy(const Case& c, double tolerance = 1e-12, double period_s = 0,
                                      const MeshStiffness* stiffness = nullptr);

struct StabilityOptions {
  SweepAxis axis;                  // key, from, to, points (log allowed)
  std::optional<SweepAxis> axis2;  // a chart: each value of axis2 is a row along axis
  double tolerance = 1e-12;        // the engine's
  std::function<bool(std::size_t, std::size_t)> progress;  // (done, total); false cancels
  std::string validate() const;
};

struct StabilitySample {
  double param = 0, param2 = 0;
  std::vector<std::complex<double>> multipliers;  // largest modulus first
  double max_multiplier = 0;
  bool stable = false;
};

struct StabilityBoundary {
  double param = 0, param2 = 0;
  BifurcationType type = BifurcationType::kFold;  // fold (+1), period_doubling (-1),
                                                  // neimark_sacker (a complex pair)
};

struct StabilityResult {
  std::vector<StabilitySample> samples;  // row by row (axis2), along axis
  std::vector<StabilityBoundary> boundaries;
  bool cancelled = false;
};

// Samples and boundaries. Throws InputError on bad input.
StabilityResult stability(const Case& c, const StabilityOptions& o);

}  // namespace geardyn
