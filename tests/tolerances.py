"""Every tolerance of the test suite, in one place, with what it is for.

Kernel round-off: two exact formulas for the same number (SymPy vs generated CasADi vs CasADi AD)
differ only by floating-point round-off, scaled by the size of the terms (energies are O(100) N*mm).
Finite differences: central differences with step h have truncation error O(h^2) and round-off
O(eps/h); with h = 1e-5 rad both are below 1e-6 relative.
Solver accuracy: IPOPT/Newton stop at a gradient norm of about 1e-8; angles are then good to
about 1e-6 rad.
"""

#: relative tolerance between two exact evaluations of the same expression (round-off)
KERNEL_RTOL = 1e-9
#: absolute floor for the same comparison, in the units of the quantity (N*mm, N*mm/rad, ...)
KERNEL_ATOL = 1e-8
#: central finite differences, step and tolerance
FD_STEP = 1e-5
FD_RTOL = 1e-6
FD_ATOL = 1e-5
#: the paper's Table 2: segment and total angles in degrees, tip in mm
TABLE2_ANGLE_DEG = 0.15
TABLE2_TIP_MM = 0.2
#: batch vs IPOPT: both stop at max |dU/dtheta| <= 1e-7 N mm/rad on Hessians of
#: O(10-1000) N mm/rad^2, so the angles of the same equilibrium agree to about 1e-8 rad
BATCH_THETA_ATOL = 1e-6
#: an equilibrium counts as stationary (the solver's own acceptance, SolverOptions.stationarity_tol)
EQUILIBRIUM_GRAD_ATOL = 1e-7
#: continuity in the loads is bounded by the linear response itself (tests/test_properties.py):
#: a small load step moves the tip by at most twice J dtheta, with H dtheta = -(dg/dload) dload

#: design, the cross-check: IPOPT and PSO designs within 0.01 mm, objectives
#: within 0.1 %
AGREE_MM = 0.01
AGREE_REL = 1e-3
#: two exact evaluations of the same stiffness (closed form + Newton ramp vs IPOPT + continuation):
#: both equilibria are stationary to ~1e-10 N mm/rad, so K agrees to ~1e-8 relative
SAME_K_REL = 1e-7
#: a multiplier against a central difference of the optimum over bound steps +-h: O(h^2) error
SENSITIVITY_REL = 1e-3
#: path following: special points located to this relative accuracy in lambda
LOCATE_RTOL = 1e-8
#: a Newton corrector converges quadratically: r_{k+1} <= C r_k^2 (measured C <= 1.7e-3 for
#: n = 1, 3, 8, 32 on Table 1, gradients in N mm/rad); the bound leaves a factor 60 for other n
QUADRATIC_CONSTANT = 0.1

#: sensitivities against central differences of solves, d theta/dp ~ (theta(p+h) - theta(p-h)) / 2h
#: with h = 1e-5 max(1, |p|): truncation O(h^2) ~ 1e-10 relative; each solve is stationary to round-off
#: after the Newton polish (theta to ~1e-12 rad), so round-off ~ 1e-12 / 1e-5 = 1e-7 relative
SENS_FD_STEP = 1e-5
SENS_FD_RTOL = 1e-5
#: ... relative to the column's size, or to these floors where a column is ~0 (rho at a target angle):
#: the differences' own noise is ~1e-12 rad / h, ~1e-7 rad and ~1e-5 mm per unit
SENS_FD_FLOOR_RAD = 1e-3
SENS_FD_FLOOR_MM = 0.1
#: the payload point's closed-form column against central differences of the generated gradient
#: (no solve: round-off only, h = 1e-6)
SENS_S_RTOL = 1e-6
#: first order against Monte Carlo at small sigma: the standard deviations of 10 000 samples have a
#: standard error of 0.7 %, and the nonlinearity at sigma = 1 % of E changes them by < 0.5 %
MC_AGREE_REL = 0.02
#: a fit to the model's own values (no noise) recovers the parameters to IPOPT's accuracy (tol 1e-10 on a
#: scaled problem): 1e-6 relative leaves room for the flat directions of the objective
FIT_EXACT_REL = 1e-6
#: the fit's implicit-function-theorem Jacobian against central differences of solves (step 1e-5 relative):
#: truncation ~1e-10, solve round-off ~1e-12 / 1e-5
FIT_JACOBIAN_RTOL = 1e-5

#: the exported C against Python's solve(): both run Newton to round-off on the same
#: generated gradient (measured <= 3e-15 rad), so 1e-9 rad (the issue's figure) leaves a margin
EXPORT_THETA_ATOL = 1e-9
#: the exported inverse against pressure_for_target (esba pressure --total-angle): the NLP stops at
#: IPOPT's tol = 1e-10 (measured pressure differences <= 8e-10 MPa, angles <= 1e-9 rad); the C runs
#: the bordered Newton to round-off
EXPORT_INVERSE_PRESSURE_ATOL = 1e-8
EXPORT_INVERSE_THETA_ATOL = 1e-8
#: the single-precision export against Python (double): float's epsilon 1.2e-7 times the
#: conditioning of the equilibria (Hessians of O(10-1000) N mm/rad^2, energies of O(100) N mm)
#: gives angles to about 2e-6 rad (measured <= 1.6e-6); the inverse's pressure to about 5e-8 MPa
EXPORT_FLOAT_THETA_ATOL = 1e-5
EXPORT_FLOAT_PRESSURE_ATOL = 1e-6
#: fold-free design: the map-based optimum (SLSQP on the fold constraint, converged to ~1e-9) against a
#: 12-particle, 15-iteration swarm (180 designs, each with its fold curves): the swarm's resolution
#: near a constraint boundary is ~0.01 mm in r2, and K changes by ~13 N/m per mm there
ENVELOPE_PSO_MM = 0.02
ENVELOPE_PSO_REL = 5e-3

#: a 3-D capability for loads in the bending plane against the planar one (issue 28): the same
#: equations on psi = tau = 0, solved to round-off by the same engine (measured ~1e-15)
REDUCES_TO_PLANAR = 1e-10
#: a special point continued in two parameters (its extended system at the line's value) against
#: the same point located on a one-parameter path by another method (the path engine's extended
#: system; maps3d's ramp with Newton on the extended system by central differences, linear near the
#: end): both converge far below it (measured ~1e-12 relative)
PATHS_AGREE_REL = 1e-6
