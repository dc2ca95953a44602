"""Beam cross-sections: a shape's area, second moments, torsion constant, shear factors and
extreme-fibre distances, about the section's local axes a1 and a2 (docs/theory-notes.md §17).

Axis 2 is the one the orientation vector fixes (OpenSees' ``vecxz``: its local z); a
rectangle or box has its width ``b`` along a1 and its height ``h`` along a2, so I1 (about a1)
= b h³/12 carries the bending in the (tangent, a2) plane.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Section", "box", "circle", "rectangle", "tube"]


@dataclass(frozen=True)
class Section:
    """Section properties (SI units).

    Attributes:
        A: area; I1, I2: second moments about a1 and a2; J: torsion constant; k1, k2: shear
        factors of the shear along a1 and a2 (shear area k A); c1, c2: extreme-fibre
        distances along a1 and a2; circular: a circle or a tube (the bending stress at the
        extreme fibre is √(M1² + M2²) c/I; else the corners' sum |M1| c2/I1 + |M2| c1/I2);
        Wt: torsional section modulus.
    """

    A: float
    I1: float
    I2: float
    J: float
    k1: float = 5.0 / 6.0
    k2: float = 5.0 / 6.0
    c1: float = 0.0
    c2: float = 0.0
    circular: bool = False
    #: Torsional section modulus (m³): the largest shear stress of a torque T is T / Wt.
    Wt: float = 0.0

    def __post_init__(self) -> None:
        if self.Wt <= 0.0:  # properties given directly: T c / J at the farthest fibre
            c = max(self.c1, self.c2)
            object.__setattr__(self, "Wt", self.J / c if c > 0.0 else math.inf)


def _rectangle_torsion(b: float, h: float) -> float:
    """Saint-Venant's torsion constant of a b × h rectangle (Roark, table 10.7: error below
    0.5 % for any aspect ratio)."""
    a, t = max(b, h) / 2.0, min(b, h) / 2.0
    return a * t**3 * (16.0 / 3.0 - 3.36 * t / a * (1.0 - t**4 / (12.0 * a**4)))


def rectangle(b: float, h: float) -> Section:
    """A solid b (along a1) × h (along a2) rectangle; shear factors 5/6."""
    return Section(
        A=b * h,
        I1=b * h**3 / 12.0,
        I2=h * b**3 / 12.0,
        J=_rectangle_torsion(b, h),
        c1=b / 2.0,
        c2=h / 2.0,
        # Roark (table 10.7): τ_max = T (3a + 1.8t) / (8 a² t²), half-sides a ≥ t.
        Wt=8.0 * max(b, h) ** 2 * min(b, h) ** 2 / 16.0 / (3.0 * max(b, h) / 2 + 0.9 * min(b, h)),
    )


def box(b: float, h: float, t_web: float, t_flange: float) -> Section:
    """A closed rectangular box girder: outer b (along a1) × h (along a2), two webs of
    ``t_web`` (parallel to a2), two flanges of ``t_flange``. J by Bredt's thin-walled formula
    on the mid-line; each shear factor the fraction of A in the walls that carry that shear
    (the webs for shear along a2, the flanges along a1)."""
    bi, hi = b - 2.0 * t_web, h - 2.0 * t_flange
    A = b * h - bi * hi
    bm, hm = b - t_web, h - t_flange  # mid-line
    J = 2.0 * t_web * t_flange * bm**2 * hm**2 / (bm * t_web + hm * t_flange)
    return Section(
        A=A,
        I1=(b * h**3 - bi * hi**3) / 12.0,
        I2=(h * b**3 - hi * bi**3) / 12.0,
        J=J,
        k1=min(1.0, 2.0 * t_flange * b / A),
        k2=min(1.0, 2.0 * t_web * h / A),
        c1=b / 2.0,
        c2=h / 2.0,
        # Bredt: τ = T / (2 A_m t), largest in the thinnest wall.
        Wt=2.0 * bm * hm * min(t_web, t_flange),
    )


def circle(d: float, nu: float) -> Section:
    """A solid circle of diameter d; Cowper's shear factor 6(1 + ν)/(7 + 6ν)."""
    r = d / 2.0
    inertia = math.pi * r**4 / 4.0
    k = 6.0 * (1.0 + nu) / (7.0 + 6.0 * nu)
    return Section(
        math.pi * r**2, inertia, inertia, 2.0 * inertia, k, k, r, r, True, 2.0 * inertia / r
    )


def tube(d: float, t: float, nu: float) -> Section:
    """A circular tube of outer diameter d and wall t; Cowper's shear factor of a hollow
    circle."""
    ro = d / 2.0
    ri = ro - t
    inertia = math.pi * (ro**4 - ri**4) / 4.0
    m2 = (ri / ro) ** 2
    k = (
        6.0
        * (1.0 + nu)
        * (1.0 + m2) ** 2
        / ((7.0 + 6.0 * nu) * (1.0 + m2) ** 2 + (20.0 + 12.0 * nu) * m2)
    )
    J = 2.0 * inertia
    return Section(math.pi * (ro**2 - ri**2), inertia, inertia, J, k, k, ro, ro, True, J / ro)
