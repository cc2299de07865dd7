"""Normal contact-force laws and friction laws (compiled parts and their parameters).

Penetration delta = -g >= 0 (m), its rate delta' = -g' (m/s), impact velocity v0 (m/s, the
approach speed delta' recorded at first touch). No law gives a tensile force: f_N >= 0.

Normal laws (``law``; the hysteresis factor chi of each is a function of the restitution e):

* ``linear`` (Kelvin-Voigt):     f_N = K delta + c delta'        (K N/m, c N s/m)
* ``hertz``:                     f_N = K delta^n                 (K N/m^n, n = 1.5)
* ``hunt_crossley`` (1975):      f_N = K delta^n (1 + chi delta'/v0),  chi = 3 (1 - e) / 2
* ``lankarani_nikravesh`` (1990):                    same form,  chi = 3 (1 - e^2) / 4
* ``flores`` (Flores et al. 2011):                   same form,  chi = 8 (1 - e) / (5 e)
* ``gonthier`` (Gonthier et al. 2004):               same form,  chi = (1 - e^2) / e
* ``carvalho_martins`` (2019):  same form, chi the exact root below for e_p = e

The restitution such a law *produces* is the root e_p of
(1 - chi e_p) = (1 + chi) exp(-chi (1 + e_p)) (:func:`produced_restitution`, derived in
docs/contact.md), independent of K, n, the mass and v0.

Friction (tangential slip velocity v_t, slip speed s = |v_t|):

    f_t = -mu(s) f_N tanh(s / v_eps) v_t / s - c_v v_t,
    mu(s) = mu_d + (mu_s - mu_d) exp(-(s / v_s)^2)

``coulomb``: mu_s = mu_d = mu; ``stribeck``: mu_s, mu_d, v_s; ``viscous``: c_v only (N s/m).
tanh(s / v_eps) regularises the sign function: a contact "sticks" by creeping at the speed
where the friction balances the tangential load, s = v_eps atanh(F_t / (mu f_N)) (creep
velocity of the order of v_eps, m/s).

``lugre`` (Canudas de Wit, Olsson, Astrom & Lischinsky, A new model for control of systems with
friction, IEEE TAC 40, 1995): bristles of stiffness sigma_0 (N/m) and damping sigma_1 (N s/m)
whose mean deflection z (m, a vector in the tangent plane, an internal state integrated with the
bodies) obeys

    z' = v_t - sigma_0 s z / g(s),   g(s) = f_N mu(s)   (the Stribeck curve above, in N)
    f_t = -(sigma_0 z + sigma_1 z' + c_v v_t)

A contact under a tangential load below mu_s f_N sticks: z settles at F_t / sigma_0 and the
slip stops (no creep), the presliding displacement being that deflection; above it, z
saturates at g(s) / sigma_0 and the friction tends to mu(s) f_N. While the contact is open the
bristles relax, z' = -z / tau (tau = ``bristle_relaxation``, s).
"""
from __future__ import annotations

import math

from ...jit import njit

NORMAL_LAWS = ("linear", "hertz", "hunt_crossley", "lankarani_nikravesh", "flores",
               "gonthier", "carvalho_martins")
LINEAR, HERTZ = 0, 1
HYSTERESIS = ("hunt_crossley", "lankarani_nikravesh", "flores", "gonthier",
              "carvalho_martins")
FRICTION_LAWS = ("none", "coulomb", "stribeck", "viscous", "lugre")
REGULARISED, LUGRE = 0, 1


def chi_hunt_crossley(e: float) -> float:
    """Hunt & Crossley (1975): chi = 3 (1 - e) / 2."""
    return 1.5 * (1.0 - e)


def chi_lankarani_nikravesh(e: float) -> float:
    """Lankarani & Nikravesh (1990): chi = 3 (1 - e^2) / 4."""
    return 0.75 * (1.0 - e * e)


def chi_flores(e: float) -> float:
    """Flores, Machado, Silva & Martins (2011): chi = 8 (1 - e) / (5 e)."""
    return 8.0 * (1.0 - e) / (5.0 * e)


def chi_gonthier(e: float) -> float:
    """Gonthier, McPhee, Lange & Piedboeuf (2004): chi = (1 - e^2) / e."""
    return (1.0 - e * e) / e


def chi_carvalho_martins(e: float) -> float:
    """Carvalho & Martins (2019), exact restitution: the chi whose produced restitution is e,
    the nonzero root of (1 - chi e) = (1 + chi) exp(-chi (1 + e)) in (0, 1/e)."""
    if e >= 1.0:
        return 0.0
    from scipy.optimize import brentq
    h = lambda c: math.log1p(c) - c * (1.0 + e) - math.log1p(-c * e)  # noqa: E731
    lo, hi = 1e-3 * (1.0 - e), (1.0 - 1e-13) / e
    while h(lo) >= 0.0 and lo > 1e-300:
        lo *= 0.1
    return float(brentq(h, lo, hi, xtol=1e-15, rtol=1e-15))


CHI = {"hunt_crossley": chi_hunt_crossley, "lankarani_nikravesh": chi_lankarani_nikravesh,
       "flores": chi_flores, "gonthier": chi_gonthier,
       "carvalho_martins": chi_carvalho_martins}


def produced_restitution(chi: float) -> float:
    """The rebound ratio e_p of f = K delta^n (1 + chi delta'/v0) for a free mass: the root in
    [0, 1] (chi e_p < 1) of (1 - chi e_p) = (1 + chi) exp(-chi (1 + e_p))."""
    if chi <= 0.0:
        return 1.0
    from scipy.optimize import brentq
    f = lambda e: math.log1p(-chi * e) - math.log1p(chi) + chi * (1.0 + e)  # noqa: E731
    hi = min(1.0, (1.0 - 1e-15) / chi)
    return float(brentq(f, 0.0, hi, xtol=1e-15)) if f(hi) < 0 else hi


# parameter columns of the laws (after the geometry's 8)
C_LAW, C_K, C_N, C_C, C_VMIN, C_MUD, C_MUS, C_VS, C_VEPS, C_CV = range(8, 18)
C_FRICTION, C_SIGMA0, C_SIGMA1, C_RELAX = range(18, 22)
N_COLUMNS = 22


@njit(inline="always")
def normal_force(param, k, delta, ddelta, v0):
    """(f_N, elastic part K delta^n, elastic energy K delta^(n+1) / (n+1)) at penetration
    delta >= 0 with rate ddelta; v0: recorded impact speed (floored at param C_VMIN)."""
    K, n = param[k, C_K], param[k, C_N]
    law = int(param[k, C_LAW])
    if law == LINEAR:
        el = K * delta
        energy = 0.5 * K * delta * delta
        f = el + param[k, C_C] * ddelta
    else:
        el = K * delta ** n
        energy = el * delta / (n + 1.0)
        f = el
        if law > HERTZ:
            vi = v0 if v0 > param[k, C_VMIN] else param[k, C_VMIN]
            f = el * (1.0 + param[k, C_C] * ddelta / vi)
    return (f if f > 0.0 else 0.0), el, energy


@njit(inline="always")
def friction_factor(param, k, fN, s):
    """(a, c_v): the friction force is f_t = -(a + c_v) v_t with a = mu(s) f_N tanh(s/v_eps)/s
    (its limit f_N mu / v_eps at s = 0)."""
    mud, mus, vs, veps, cv = (param[k, C_MUD], param[k, C_MUS], param[k, C_VS],
                              param[k, C_VEPS], param[k, C_CV])
    mu = mud
    if mus != mud and vs > 0.0:
        mu = mud + (mus - mud) * math.exp(-(s / vs) ** 2)
    a = 0.0
    if mu > 0.0 and fN > 0.0:
        x = s / veps
        a = mu * fN * (math.tanh(x) / s if x > 1e-8 else 1.0 / veps)
    return a, cv


@njit
def lugre(param, k, fN, vt, z):
    """(f_t, z', sigma_0 z . z' (the rate of the bristles' energy), bristle energy) of the
    LuGre law at normal force fN, slip velocity vt and bristle deflection z (both tangent;
    3-tuples)."""
    s0, s1, cv = param[k, C_SIGMA0], param[k, C_SIGMA1], param[k, C_CV]
    s = math.sqrt(vt[0] * vt[0] + vt[1] * vt[1] + vt[2] * vt[2])
    mud, mus, vs = param[k, C_MUD], param[k, C_MUS], param[k, C_VS]
    mu = mud
    if mus != mud and vs > 0.0:
        mu = mud + (mus - mud) * math.exp(-(s / vs) ** 2)
    g = mu * fN
    if g > 0.0:
        c = s0 * s / g
        zd = (vt[0] - c * z[0], vt[1] - c * z[1], vt[2] - c * z[2])
        ft = (-(s0 * z[0] + s1 * zd[0] + cv * vt[0]), -(s0 * z[1] + s1 * zd[1] + cv * vt[1]),
              -(s0 * z[2] + s1 * zd[2] + cv * vt[2]))
    else:                                       # unloaded: the bristles relax
        r = 1.0 / param[k, C_RELAX]
        zd = (-r * z[0], -r * z[1], -r * z[2])
        ft = (-cv * vt[0], -cv * vt[1], -cv * vt[2])
    zz = z[0] * z[0] + z[1] * z[1] + z[2] * z[2]
    return ft, zd, s0 * (z[0] * zd[0] + z[1] * zd[1] + z[2] * zd[2]), 0.5 * s0 * zz
