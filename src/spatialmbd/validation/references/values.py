"""Every reference value of references.json with its provenance: :func:`derive`."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy.special import ellipk

from ... import models
from ..exact import EulerFreeBody, PhysicalPendulum, heavy_top_steady_precession
from .tables import FREE_ASYMMETRIC, FREE_SYMMETRIC, adams_accuracy, model_case_entries


def derive(adams_dir: Path) -> dict:
    """Every reference value with its provenance."""
    g = models.G_TEXT
    refs = {"_about": (
        "Reference values of the spatialmbd validation suite, with provenance (source, how "
        "obtained, precision). Derived values are recomputed by `python -m "
        "spatialmbd.validation.references --write`; the tests check they still agree.")}

    refs["adams"] = {
        "source": ("MSC ADAMS results for single-joint spatial pendulums published by Project "
                   "Chrono (BSD-3 licence) in data/testing/joints/ of "
                   "github.com/projectchrono/chrono, commit "
                   "7689fbc02d12c5419fa6acad8791100fd89979dd; copied unchanged into "
                   "spatialmbd/validation/data/adams/ (see PROVENANCE.md there)"),
        "how": ("ADAMS/Solver runs of the decks test_<case>.adm (1 kg, 4 m pendulum, centre "
                "of mass 2 m from the joint, gravity 9.80665 m/s^2 along -z, released at rest "
                "horizontally; Prismatic/Cylindrical: the same body on a translational/"
                "cylindrical joint; Distance: held by a distance constraint GCON DM(a, b) - 2 "
                "at its centre of mass (Case01) or at a point 2 m from it (Case02/03); "
                "TranSpring_Case02: the body free on a translational spring-damper SFORCE from "
                "the origin, natural length 2 m; RotSpring_Case01: the Revolute_Case01 pendulum "
                "with a torsional spring-damper SFORCE about the joint axis (Case02: its "
                "stiffness 50 + 10 |theta| N m/rad, no deck of its own); RevSpherical: no "
                "deck, the model of Chrono's unit test rebuilt in code, the 1 kg pendulum on a "
                "revolute-spherical link 2 m long; LinActuator: no deck either, a 1 kg plate "
                "driven at constant speed along a prismatic joint by a linear actuator); "
                "REQUEST "
                "output every 0.01 s for 0..5 s. Reactions (Rforce, Rtorque) act on the ground "
                "part (I marker) about the I marker, in global axes (with a spring-damper: "
                "its load on the ground, added to the joint's; RevSpherical: Rforce/Rtorque_Body1 "
                "on the ground about the revolute point, _Body2 on the pendulum about the "
                "spherical point; LinActuator: RforceP/RtorqueP the prismatic joint's on the ground "
                "about the origin, RforceA/RtorqueA the actuator's on the plate)."),
        "precision": ("7 significant digits as printed; the ADAMS integration error against "
                      "the exact elliptic solution is listed per quantity "
                      "(adams_error_vs_exact_*, max/RMS over the 501 rows, rounded up to 2 "
                      "digits; computed here with validation.exact.PhysicalPendulum, "
                      "AxialMotion and DistancePendulum); for the cases without a closed form "
                      "(exact: null) the RMS tolerance per column that Project Chrono's unit "
                      "test accepts against the same tables (chrono_rms_tolerance, "
                      "chrono_test)"),
        "cases": {**adams_accuracy(adams_dir), **model_case_entries(adams_dir)},
    }

    a01 = models.simple_pendulum_a01()
    body = a01.bodies["mass"]
    pend = PhysicalPendulum(body.mass, body.inertia, body.r, np.eye(3), (0, 0, 0), (0, 0, 1),
                            a01.gravity)
    T_point = 4 * math.sqrt(1.0 / g) * float(ellipk(0.5))
    refs["iftomm_a01"] = {
        "source": "IFToMM benchmark A01 (IFToMM benchmark library, after Gonzalez et al., Multibody Syst. Dyn. 16, 2006): 1 kg, 1 m, from "
                  "the horizontal at x = +1 m, gravity 9.81 m/s^2 along -y",
        "how": ("exact large-amplitude pendulum, T = 4 sqrt(I_O / (m g d)) K(1/2) with "
                "I_O = m L^2 + I_c; the model's point mass has I_c = 1e-6 kg m^2"),
        "precision": "closed form, evaluated in double precision",
        "period_s": pend.period, "period_point_mass_s": T_point, "I_O": pend.I_O,
    }

    top = models.HEAVY_TOP
    omega_p = heavy_top_steady_precession(top["mass"], top["l"], top["I1"], top["I3"], g,
                                          top["theta"], top["spin"])
    refs["heavy_top"] = {
        "source": "constructed (models.heavy_top / models.HEAVY_TOP data)",
        "how": ("steady precession of a heavy symmetric top: slow root of "
                "A Omega^2 cos(theta) - C w3 Omega + m g l = 0 (A = I1 + m l^2, C = I3)"),
        "precision": "closed form, evaluated in double precision",
        "theta_rad": top["theta"], "spin_w3": top["spin"], "precession_rate": omega_p,
    }

    from ..exact import NutatingTop
    nut = NutatingTop(top["mass"], top["l"], top["I1"], top["I3"], 9.81, math.pi / 3, 20.0,
                      0.0)
    refs["heavy_top_nutation"] = {
        "source": ("constructed (models.heavy_top / models.HEAVY_TOP data): the heavy "
                   "symmetric top released with its axis 60 deg from the vertical, spinning at "
                   "20 rad/s about it, not precessing (H. Goldstein, Classical Mechanics, sec. "
                   "5.7: the cusped nutation)"),
        "how": ("u = cos(theta) oscillates between the first two roots of the cubic u'^2 = "
                "(1 - u^2)(alpha - beta u) - (b - a u)^2: u(t) = u1 + (u2 - u1) sn^2(lam t + "
                "K | m) (validation.exact.NutatingTop); the spin w3 and the angular momentum "
                "about the vertical p_phi = A b are conserved"),
        "precision": "closed form (cubic roots, Jacobi elliptic functions), double precision",
        "theta0_rad": math.pi / 3, "spin_w3": 20.0, "precession0": 0.0,
        "u1": nut.u1, "u2": nut.u2, "nutation_period_s": nut.period, "p_phi": nut.p_phi(),
    }

    fs = FREE_SYMMETRIC
    I1, I3 = fs["inertia"][0], fs["inertia"][2]
    refs["free_symmetric"] = {
        "source": "constructed (validation.references.FREE_SYMMETRIC)",
        "how": ("Euler's equations, I1 = I2: body-axis angular velocity precesses at "
                "lambda = (I3 - I1)/I1 w3; A(t) = R_h(|H|/I1 t) A0 R_3(-lambda t)"),
        "precision": "closed form",
        "data": fs, "lambda": (I3 - I1) / I1 * fs["omega_local"][2],
    }
    fa = FREE_ASYMMETRIC
    efb = EulerFreeBody(fa["inertia"], fa["omega_local"][1], fa["omega_local"][2])
    refs["free_asymmetric"] = {
        "source": "constructed (validation.references.FREE_ASYMMETRIC)",
        "how": ("Jacobi's solution of Euler's equations (validation.exact.EulerFreeBody): "
                "w2 = a2 sn(lambda t + K(m) | m) changes sign every 2 K(m) / lambda"),
        "precision": "closed form",
        "data": fa, "flip_time_s": efb.flip_time, "elliptic_parameter_m": efb.m,
        "lambda": efb.lam,
    }

    nfb = models.n_four_bar(2)
    Ic = float(nfb.bodies["crank0"].inertia[2, 2])
    N, m, L = 2, 1.0, 1.0
    refs["iftomm_a02"] = {
        "source": "IFToMM benchmark A02, N = 2 (IFToMM benchmark library, after Gonzalez et al., Multibody Syst. Dyn. 16, 2006)",
        "how": ("parallelogram branch: I phi'' = K sin phi, I = (N+1)(I_c + m L^2/4) + N m L^2 "
                "with the model's bar inertia I_c (the published slender-bar I_c = m L^2/12 gives "
                "m L^2 ((N+1)/3 + N)), K = m g L ((N+1)/2 + N); from phi = 0, phi' = -1 rad/s "
                "over the top: validation.exact.rotating_pendulum"),
        "precision": "closed form",
        "I": (N + 1) * (Ic + m * L * L / 4) + N * m * L * L,
        "I_published_thin_bar": m * L * L * ((N + 1) / 3 + N),
        "K": m * g * L * ((N + 1) / 2 + N),
    }

    refs["iftomm_a03"] = {
        "source": ("IFToMM benchmark A03, Andrews' squeezer mechanism (IFToMM benchmark library; "
                   "Hairer & Wanner, Solving Ordinary Differential Equations II, sec. VII.7, after "
                   "Schiehlen, Multibody Systems Handbook, 1990): reference solution at t = 0.03 s "
                   "of the Test Set for IVP Solvers (F. Mazzia, C. Magherini, problem 'andrews', "
                   "revision 1.2, 2006)"),
        "how": ("published: PSIDE with rtol = atol = 1e-14 on a Cray C90, the seven relative "
                "angles (beta, Theta, gamma, Phi, delta, Omega, epsilon), their rates and "
                "second derivatives"),
        "precision": ("16 digits printed; about 10 correct: two independent converged "
                      "solutions (spatialmbd's body coordinates with dop853 at rtol 1e-13, and "
                      "the test set's own relative-coordinate equations reduced to index 1 and "
                      "integrated by SciPy's DOP853 at rtol 1e-13) agree with each other to "
                      "3e-11 rad and both differ from it by up to 1.43e-9 rad, 5.4e-7 rad/s "
                      "and 0.058 rad/s^2"),
        "t_s": 0.03,
        "angles_rad": [15.81077119629904, -15.75637105984298, 0.04082224013073101,
                       -0.5347301163226948, 0.5244099658805304, 0.5347301163226948,
                       1.048080741042263],
        "rates_rad_s": [1139.920302151208, -1424.379294994111, 11.03291221937134,
                        19.29337464421385, 0.5735699284790808, -19.29337464421385,
                        0.3231791658026955],
        "accelerations_rad_s2": [-24631.76316945196, 51850.37701610329, 324102.5686413781,
                                 566749.3645176213, 16743.62929479361, -566749.3645176222,
                                 9826.520791458422],
        "uncertainty": {"angles_rad": 2e-9, "rates_rad_s": 1e-6,
                        "accelerations_rad_s2": 0.1},
    }

    refs["iftomm_a04"] = {
        "source": "IFToMM benchmark A04 Bricard mechanism (IFToMM benchmark library, after Gonzalez et al., Multibody Syst. Dyn. 16, 2006)",
        "how": "published: Gruebler-Kutzbach 0 DoF, actual mobility 1 (one redundant equation)",
        "precision": "exact integers",
        "grubler": 0, "dof": 1, "redundant_equations": 1,
        "exudyn": dict(how=EXUDYN_HOW,
                       t_s=10.0, steps=[0.0002, 0.0001], com=[
                           [0.499999981905, 0.0, -0.000134516955],
                           [0.999865483041, -0.499999981915, -0.000268997729],
                           [0.999865483041, -1.00013448078, 0.499731002271],
                           [0.499999981905, -1.00013448078, 0.999731002271],
                           [0.0, -0.499999981915, 0.999865519225]],
                       step_difference=6.34e-09),
    }

    refs["iftomm_a05"] = {
        "source": "IFToMM benchmark A05 flyball governor (IFToMM benchmark library, after Gonzalez et al., Multibody Syst. Dyn. 16, 2006)",
        "how": ("no torque about the shaft axis: angular momentum about z conserved; "
                "mechanical energy + elastic energy - damper work conserved"),
        "precision": "invariants (exact)",
        "exudyn": dict(how=EXUDYN_HOW,
                       t_s=2.0, steps=[5e-05, 2.5e-05], com=[
                           [0.0, 0.0, 0.5],
                           [0.0, -0.0, 0.505909295927],
                           [0.158175457669, -0.880773929158, 0.519998471181],
                           [-0.158175457669, 0.880773929158, 0.519998471181]],
                       step_difference=5.05e-08),
    }

    sc = models.slider_crank_iftomm()
    V = sum(bd.mass * g * bd.r[2] for bd in sc.bodies.values())
    refs["spatial_slider_crank"] = {
        "source": ("IFToMM spatial rigid slider-crank (pre-revision data), "
                   "IFToMM benchmark library (after Gonzalez et al., Multibody Syst. Dyn. 16, 2006): "
                   "'one published implementation finds "
                   "0.76643568 J' (datum z = 0, initial velocities consistent with the joints)"),
        "how": "published value",
        "precision": "8 decimals (+-5e-9 J)",
        "energy_J": 0.76643568,
        "potential_J": V,
        "kinetic_J": 0.76643568 - V,
        "note": ("reproduced with the universal joint's cross axes x (slider) and "
                 "(0, -2, 1)/sqrt 5 (rod) and the crank speed held at 6 rad/s in the "
                 "velocity correction (models.slider_crank_iftomm); models.slider_crank's "
                 "axes give 0.76662000 J"),
        "exudyn": dict(how=EXUDYN_HOW + "; from the velocities of the initial "
                       "correction with the crank's 6 rad/s held",
                       t_s=2.0, steps=[0.0001, 5e-05], com=[
                           [0.0, 0.068214654268, 0.095716429491],
                           [0.144542599376, 0.018214654268, 0.035716429491],
                           [0.289085198752, 0.0, 0.0]],
                       step_difference=3.38e-07),
    }

    refs["slider_crank_kinematics"] = {
        "source": "models.slider_crank_exact (closed form x = sqrt(L^2 - |B_yz|^2))",
        "how": "closed-form slider position, velocity, acceleration at constant crank speed",
        "precision": "closed form",
    }
    refs["hertz_impact"] = {
        "source": ("Hertz contact theory: K = 4/3 E* sqrt(R), E* = E / (1 - nu^2) for a sphere on "
                   "a rigid flat; impact of elastic bodies (K. L. Johnson, Contact Mechanics, "
                   "Cambridge 1985, ch. 11)"),
        "how": ("energy balance m v0^2 / 2 = 2/5 K d_max^(5/2) gives d_max and the peak force "
                "K d_max^(3/2); the duration T = 2 (d_max / v0) int_0^1 dx / sqrt(1 - x^(5/2)) "
                "= 2.94 d_max / v0 (quadrature); elastic: rebound at v0"),
        "precision": "closed form, evaluated in double precision",
        "radius_m": 0.1, "mass_kg": 1.0, "young_Pa": 2.0e11, "poisson": 0.3, "v0_m_s": 1.0,
    }
    refs["cam_follower"] = {
        "source": "constructed (models.cam_follower, models.cam_profile)",
        "how": ("the follower's height is the profile r(pi/2 - w t), r SciPy's periodic cubic "
                "spline through the same radii (an independent implementation); Newton's law "
                "for the follower along its guide, m y'' = F_spring + N n_y, gives the normal "
                "force N, n the outward profile normal turned by the cam angle"),
        "precision": "closed form, evaluated in double precision",
    }
    refs["meijaard_bicycle"] = {
        "source": ("J. P. Meijaard, J. M. Papadopoulos, A. Ruina, A. L. Schwab, Linearized "
                   "dynamics equations for the balance and steer of a bicycle: a benchmark and "
                   "review, Proc. R. Soc. A 463 (2007) 1955-1982: the benchmark bicycle's "
                   "parameters (models.MEIJAARD), the coefficient matrices of its lean and "
                   "steer equations M q'' + v C1 q' + (g K0 + v^2 K2) q = 0, q = (lean, "
                   "steer), printed to 14 digits, and its weave and capsize speeds"),
        "how": ("published (the authors derived the equations by hand and checked them with "
                "independent multibody codes); the eigenvalues at each speed are those of "
                "these matrices (exact.bicycle_eigenvalues)"),
        "precision": "14 significant digits",
        "g": 9.81,
        "M": [[80.81722, 2.31941332208709], [2.31941332208709, 0.29784188199686]],
        "C1": [[0.0, 33.86641391492494], [-0.85035641456978, 1.68540397397560]],
        "K0": [[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]],
        "K2": [[0.0, 76.59734589573222], [0.0, 2.65431523794604]],
        "weave_speed_m_s": 4.29238253634111,
        "capsize_speed_m_s": 6.02426201538837,
    }
    refs["double_pendulum"] = {
        "source": "constructed (models.double_pendulum): two rods on revolute joints, chaotic",
        "how": ("invariants (energy, constraints) over the run, and the first 2 s against an "
                "independent code"),
        "precision": "invariants exact; the independent code to its step error",
        "exudyn": dict(how=EXUDYN_HOW,
                       t_s=2.0, steps=[5e-05, 2.5e-05], com=[
                           [-0.0, 0.440721093114, -0.23614596775],
                           [0.490314623349, 0.927696834538, -0.38596651839]],
                       step_difference=3.7e-08),
    }
    refs["iftomm_bicycle"] = {
        "source": ("IFToMM benchmark library, uncontrolled bicycle: the Meijaard et al. (2007) "
                   "bicycle (models.whipple_bicycle) started upright and straight, pushed "
                   "sideways: M1 4.0 m/s at 0.05 rad/s, M2 4.6 m/s at 0.5 rad/s, M3 8.0 m/s at "
                   "0.05 rad/s; the library's own reference solutions are not reachable here"),
        "how": ("an independent code instead: Exudyn 1.13.6 (Euler-parameter rigid bodies, its "
                "revolute joints and exact ObjectJointRollingDisc, generalized-alpha rho_inf "
                "0.9, modified Newton at its default tolerances) on the same data, at the "
                "fixed steps 1.25e-4 s and 6.25e-5 s; the centres of mass of the four bodies "
                "(rear frame, rear wheel, front frame, front wheel) at t = 5 s at the finer "
                "step (bench/exudyn_references.py)"),
        "precision": ("second order in the step: the finer step's error is about a third of "
                      "the two steps' difference (step_difference); plus Exudyn's Newton "
                      "tolerance (relative 1e-8 of the positions)"),
        "t_s": 5.0,
        "steps": [1.25e-4, 6.25e-5],
        "manoeuvres": {
            "M1": dict(speed=4.0, lean_rate=0.05, com=[
                      [20.292743251956, -0.312856580591, 0.899987752423],
                      [19.995957823359, -0.268934994681, 0.299996666103],
                      [20.885068528335, -0.40837278796, 0.699982863612],
                      [21.003297746395, -0.428952544363, 0.349985255587]],
                       step_difference=7.44e-08),
            "M2": dict(speed=4.6, lean_rate=0.5, com=[
                      [22.875584316537, -4.901594292056, 0.899949739991],
                      [22.583886640438, -4.831213023375, 0.299983955319],
                      [23.462027663681, -5.028420718453, 0.699953705213],
                      [23.580000227414, -5.05065998195, 0.349971006547]],
                       step_difference=3.03e-07),
            "M3": dict(speed=8.0, lean_rate=0.05, com=[
                      [40.292636910491, -0.739458109184, 0.899982442772],
                      [39.992925888549, -0.725768470791, 0.299994195282],
                      [40.892346524022, -0.758159271463, 0.699985859557],
                      [41.012352292675, -0.759972881513, 0.349992536323]],
                       step_difference=9.42e-08),
        },
    }
    refs["basu_mandal_bicycle"] = {
        "source": ("P. Basu-Mandal, A. Chatterjee, J. M. Papadopoulos, Hands-free circular "
                   "motions of a benchmark bicycle, Proc. R. Soc. A 463 (2007) 1983-2003, "
                   "Table 1: a general state of the Meijaard et al. (2007) benchmark bicycle "
                   "(leaning 35.6 deg, steered, pitched, turning) and the accelerations of the "
                   "nonlinear equations of motion there, as transcribed with their significant "
                   "digits in the DynamicistToolKit (dtk.bicycle.basu_table_one_input, "
                   "basu_table_one_output, basu_sig_figs)"),
        "how": ("published: two independent derivations of the nonlinear equations of motion "
                "agreeing to the digits printed; Basu-Mandal's coordinates: rear wheel centre "
                "(x, y, z), yaw theta, "
                "lean psi, pitch phi, steer psif, wheel angles betar, betaf "
                "(validation.bicycle)"),
        "precision": "12 to 14 significant digits (sig_figs; 0: an exact zero)",
        "state": {"x": 0.0, "y": 0.0, "z": 0.2440472102925, "theta": 0.0,
                  "psi": 0.9501292851472, "phi": 3.1257073014894, "psif": 0.2311385135743,
                  "betar": 0.0, "betaf": 0.0, "xd": -2.8069345714545,
                  "yd": -0.1480982396001, "zd": 0.1058778746261, "thetad": 0.7830033527065,
                  "psid": 0.6068425835418, "phid": -0.0119185528069,
                  "psifd": 0.4859824687093, "betard": 8.9129896614890,
                  "betafd": 8.0133620584155},
        "accelerations": {"xdd": -0.5041626315047, "ydd": -0.3449706619454,
                          "zdd": -1.4604528332980, "thetadd": 0.8353281706379,
                          "psidd": -7.8555281128244, "phidd": 0.1205543897884,
                          "psifdd": -4.6198904039403, "betardd": 1.8472554144217,
                          "betafdd": 2.4548072904550},
        "sig_figs": {"x": 0, "y": 0, "z": 13, "theta": 0, "psi": 13, "phi": 14, "psif": 13,
                     "betar": 0, "betaf": 0, "xd": 14, "yd": 13, "zd": 13, "thetad": 13,
                     "psid": 13, "phid": 12, "psifd": 13, "betard": 13, "betafd": 14,
                     "xdd": 13, "ydd": 13, "zdd": 13, "thetadd": 13, "psidd": 14,
                     "phidd": 13, "psifdd": 14, "betardd": 14, "betafdd": 13},
    }
    return refs


#: provenance of the references computed with Exudyn (validation cases iftomm_a04, iftomm_a05)
EXUDYN_HOW = ("Exudyn 1.13.6, an independent code (Euler-parameter rigid bodies, its own "
              "joints and spring-dampers, generalized-alpha rho_inf 0.9, modified Newton at "
              "its default tolerances), on the same model data at two fixed steps; the "
              "centres of mass of every body at the end at the finer step "
              "(bench/exudyn_references.py)")
