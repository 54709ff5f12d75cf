"""Stiffness of a deep-groove ball bearing from its geometry and its load, for ``[bearings]``.

The coupled model (docs/model.md) takes each bearing as a linear spring. A ball bearing is not
linear: its balls are Hertzian contacts, so its stiffness grows with its load. This module gives
the tangent stiffness at an operating load, which is what the coupled model linearises about:

- each ball's two contacts (inner and outer raceway) by Hertz's theory with the closed-form
  ellipticity and elliptic integrals of Hamrock and Brewe (J. Lubr. Technol. 105, 1983), steel on
  steel;
- radial load, zero operating clearance: the balls' loads summed exactly over their angular
  positions (the ring displaced by delta_r loads ball j with Q_j = K_n (delta_r cos psi_j)^1.5);
- axial load, zero clearance: every ball at the same contact angle, which grows with the axial
  displacement from the distance of the raceway curvature centres (f_i + f_o - 1) D_w.

Checked (tests/python/test_geardyn.py): the contact of the 6206 worked example of eng-tools.dev
(semi-axes, peak pressure, ellipticity) to 0.1 %, and the radial and axial deflections of the
deep-groove bearing of ISO/TS 16281's examples 1 and 2 (16.99 um and 138.9 um under 1000 N) to
2 %. The stiffness is the exact derivative of the load-deflection relation, checked against
central differences.
"""

import math
from dataclasses import dataclass

__all__ = ["BallBearing"]


@dataclass(frozen=True)
class BallBearing:
    """A deep-groove ball bearing, steel on steel unless told.

    Parameters
    ----------
    balls : int
        Number of balls Z.
    ball_diameter_mm, pitch_diameter_mm : float
        D_w and the pitch circle diameter D_pw.
    inner_groove_radius_mm, outer_groove_radius_mm : float
        Raceway groove radii r_i, r_o (conformities r / D_w above 0.5).
    youngs_modulus_gpa, poisson_ratio : float
        Of balls and rings.
    """

    balls: int
    ball_diameter_mm: float
    pitch_diameter_mm: float
    inner_groove_radius_mm: float
    outer_groove_radius_mm: float
    youngs_modulus_gpa: float = 210.0
    poisson_ratio: float = 0.3

    def __post_init__(self):
        d = self.ball_diameter_mm
        checks = [("balls", self.balls, self.balls >= 3, "an integer >= 3"),
                  ("ball_diameter_mm", d, d > 0, "> 0"),
                  ("pitch_diameter_mm", self.pitch_diameter_mm, self.pitch_diameter_mm > d,
                   "> ball_diameter_mm"),
                  ("inner_groove_radius_mm", self.inner_groove_radius_mm,
                   self.inner_groove_radius_mm > d / 2, "> ball_diameter_mm / 2"),
                  ("outer_groove_radius_mm", self.outer_groove_radius_mm,
                   self.outer_groove_radius_mm > d / 2, "> ball_diameter_mm / 2"),
                  ("youngs_modulus_gpa", self.youngs_modulus_gpa, self.youngs_modulus_gpa > 0,
                   "> 0"),
                  ("poisson_ratio", self.poisson_ratio, 0 <= self.poisson_ratio < 0.5,
                   "in [0, 0.5)")]
        for name, value, ok, allowed in checks:
            if not ok:
                raise ValueError(f"BallBearing: {name} = {value}: must be {allowed}")

    # Hertz --------------------------------------------------------------------------------

    def _radii_mm(self, ring):
        """(R_x, R_y) of a ball's contact with the inner or the outer raceway, mm."""
        rb = self.ball_diameter_mm / 2
        gamma = self.ball_diameter_mm / self.pitch_diameter_mm
        if ring == "inner":
            return rb * (1 - gamma), self.inner_groove_radius_mm * rb / (
                self.inner_groove_radius_mm - rb)
        if ring == "outer":
            return rb * (1 + gamma), self.outer_groove_radius_mm * rb / (
                self.outer_groove_radius_mm - rb)
        raise ValueError(f"ring = {ring!r}: must be 'inner' or 'outer'")

    def contact(self, load_n, ring):
        """One ball's contact with a raceway under the normal load `load_n`.

        Returns
        -------
        dict
            ``deflection_um`` (the approach of the two bodies), ``semi_axes_mm`` (a, b),
            ``peak_pressure_mpa``, ``ellipticity`` (a / b), ``effective_radius_mm`` and
            ``reduced_modulus_gpa`` E* = E / (2 (1 - nu^2)).
        """
        rx, ry = self._radii_mm(ring)
        r = 1 / (1 / rx + 1 / ry)
        ratio = ry / rx
        k = 1.0339 * ratio ** 0.636  # Hamrock-Brewe's closed forms
        e_ell = 1.0003 + 0.5968 / ratio
        f_ell = 1.5277 + 0.6023 * math.log(ratio)
        e_prime = self.youngs_modulus_gpa * 1e3 / (1 - self.poisson_ratio ** 2)  # MPa
        q = load_n
        deflection = f_ell * (9 / (2 * e_ell * r) * (q / (math.pi * k * e_prime)) ** 2) ** (1 / 3)
        a = (6 * k * k * e_ell * q * r / (math.pi * e_prime)) ** (1 / 3)
        b = (6 * e_ell * q * r / (math.pi * k * e_prime)) ** (1 / 3)
        return {"deflection_um": deflection * 1e3, "semi_axes_mm": (a, b),
                "peak_pressure_mpa": 3 * q / (2 * math.pi * a * b), "ellipticity": k,
                "effective_radius_mm": r, "reduced_modulus_gpa": e_prime / 2e3}

    def _ball_constant(self):
        """K_n of Q = K_n delta^1.5 for one ball between both rings, N/m^1.5 (delta in m)."""
        q = 1.0
        delta_m = (self.contact(q, "inner")["deflection_um"] +
                   self.contact(q, "outer")["deflection_um"]) * 1e-6
        return q / delta_m ** 1.5

    # The bearing --------------------------------------------------------------------------

    def radial(self, load_n):
        """Radial deflection and tangent stiffness under a radial load, zero clearance.

        Returns
        -------
        (float, float)
            delta_r in m and dF_r / d delta_r in N/m.
        """
        if not load_n > 0:
            raise ValueError(f"radial load_n = {load_n}: must be > 0 N")
        kn = self._ball_constant()
        # F_r = K_n delta_r^1.5 sum_j max(cos psi_j, 0)^2.5, exactly.
        shape = sum(max(math.cos(2 * math.pi * j / self.balls), 0.0) ** 2.5
                    for j in range(self.balls))
        delta = (load_n / (kn * shape)) ** (2 / 3)
        return delta, 1.5 * load_n / delta

    def _axial_load(self, delta_a, kn, a0):
        s = math.hypot(a0, delta_a)
        delta = s - a0
        return self.balls * kn * delta ** 1.5 * delta_a / s, s, delta

    def axial(self, load_n):
        """Axial deflection and tangent stiffness under an axial load, zero clearance.

        Returns
        -------
        (float, float)
            delta_a in m and dF_a / d delta_a in N/m.
        """
        if not load_n > 0:
            raise ValueError(f"axial load_n = {load_n}: must be > 0 N")
        kn = self._ball_constant()
        a0 = (self.inner_groove_radius_mm + self.outer_groove_radius_mm -
              self.ball_diameter_mm) * 1e-3  # (f_i + f_o - 1) D_w, m
        lo, hi = 0.0, a0
        while self._axial_load(hi, kn, a0)[0] < load_n:
            hi *= 2
        for _ in range(200):  # bisection: the load grows monotonically with delta_a
            mid = (lo + hi) / 2
            if self._axial_load(mid, kn, a0)[0] < load_n:
                lo = mid
            else:
                hi = mid
            if hi - lo <= 1e-15 * hi:
                break
        delta_a = (lo + hi) / 2
        _, s, delta = self._axial_load(delta_a, kn, a0)
        # d/d delta_a of Z K_n delta^1.5 delta_a / s with delta = s - a0, s = hypot(a0, delta_a).
        stiffness = self.balls * kn * (1.5 * delta ** 0.5 * (delta_a / s) ** 2 +
                                       delta ** 1.5 * a0 * a0 / s ** 3)
        return delta_a, stiffness
