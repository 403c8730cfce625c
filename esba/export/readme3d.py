"""The README of a 3-D export (:mod:`esba.export.spatial`)."""

from __future__ import annotations

from .ccode import TOLERANCES
from .writer import flag_table

STATUS_TABLE3D = """| code | name | meaning |
|---|---|---|
| 0 | `ESBA_OK` | converged on a stable equilibrium (evaluations: done) |
| 1 | `ESBA_UNSTABLE` | converged on an equilibrium that is not stable (a saddle, or critical) |
| 2 | `ESBA_SNAPPED` | the load path snapped at a fold whose critical mode lies in the bending plane: the stable state after the jump, taken on to the full load (`snap_*` say where) |
| 3 | `ESBA_UNREACHABLE` | no stable state of the branch meets the target: the nearest reachable one is returned |
| 4 | `ESBA_NOT_CONVERGED` | an iteration limit was met: the last good state is returned |
| 5 | `ESBA_OUT_OF_DOMAIN` | the state would leave the model's domain (Eq. 10: the chamber closes) |
| 6 | `ESBA_BAD_INPUT` | a load or target not allowed: NaN, infinite, negative pressure or force, `at` outside (0, 1], a zero gravity direction, NULL |
| 7 | `ESBA_BAD_PARAMETERS` | actuator parameters outside their ranges (L, r1, r2, E, EI_side, GJ > 0; d, M >= 0; r2 + d < r1; 0 <= rho < pi/2) |
| 8 | `ESBA_BAD_SIZE` | `n` is not the segment count of this export |
| 9 | `ESBA_BUCKLED` | the stable branch ended with a critical mode out of the bending plane (more than half of its squared norm in psi and tau): the actuator flipped sideways (lateral-torsional buckling, or a fold out of the plane); the state it landed in, taken on to the full load (`snap_*`, `sideways`) |
"""


def readme3d(spec, command: str, example: tuple[str, str, str]) -> str:
    name = spec.name
    inp, out, _ = example
    sec = spec.section_values()
    tol = TOLERANCES[spec.precision]
    return f"""# {name}: the esba 3-D model as C

Exported by `{command}` (esba): the spatial model with n = {spec.n} segments (three rotations a
joint: the in-plane bend theta, the sideways bend psi, the twist tau), effects
`{spec.effects.spec()}`, variant `{spec.variant}`, in **{spec.precision}** precision, as C99 that depends on
nothing but libm. No `malloc`, no global mutable state (every call works in the caller's
`{name}_work`, so calls on different works may run in parallel), and every loop is bounded.
The actuator's parameters, the section's sideways and torsional stiffnesses among them, and every
load (a payload's direction in space and its point, the moments, gravity's direction) are passed
at run time. Do not edit these files: export again. `esba-export.json` lists them with their SHA-256.

## Build

    make            # the demo: cc -std=c99 -O2 demo.c {name}.c -lm
    make check      # every warning an error: -std=c99 -Wall -Wextra -Werror -pedantic
    make cortex-m4  # arm-none-eabi-gcc -mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16 -Os

## The demo

`./demo` reads lines `pressure_MPa{' [force_N angle_deg [out_of_plane_deg [at]]]' if spec.payloads == 1 else (' then, per payload, force_N angle_deg out_of_plane_deg at' if spec.payloads else '')}
(a payload's in-plane direction from the vertical, 90 = horizontal against the bend; its angle out
of the bending plane, toward +z; `at` the fraction of the length, default 1 = the tip) and prints
the angles theta, psi, tau of every segment (degrees), the total in-plane angle, the tip (x, y,
z, mm) and the status, for the paper's Table 1 actuator with the section stiffnesses
EI_side = {sec['EI_side']:.6g} and GJ = {sec['GJ']:.6g} N mm^2; then `flags` when the result has any.
`./demo -i` reads the total in-plane angle in degrees first and prints the pressure that reaches
it under the payloads, then the same. The exit code is 0 when every line was answered, 1 when a
line was refused, 2 for a wrong argument.

Example (Table 1 at {inp.split()[0]} MPa{', a 1 N tip payload, horizontal in the plane and 30 degrees out of it' if spec.payloads else ''}; Python's `solve3d` gives the same):

    $ echo '{inp}' | ./demo
    {out}

## Units and frames

mm, N, MPa, N mm; angles in radians in the API; M in kg, g in m/s^2. Base frame: x down the unbent
axis, y toward the bending side, z = x cross y. The state is q = [theta_1..n, psi_1..n, tau_1..n].

## API ({name}.h)

Every function takes `n` (must be {spec.n}: `ESBA_BAD_SIZE` otherwise), the actuator
(`{name}_params`: L, r1, r2, d, rho, E, M, EI_side, GJ) and the loads (`{name}_loads`: `pressure`,
`payload[k]` = {{force, angle, out_of_plane, at}}, `moment[k]` = {{m[3], at}} where the model has
moments, `g` and `down[3]`, gravity's direction, where it has the weight), and returns a status
code (also in `out->status`). Results are always finite: on bad input they are zeros.

- `{name}_equilibrium(n, params, loads, from, out, work)`: the equilibrium reached along the load
  history: from the straight state (`from == NULL`) the pressure is raised with the other loads
  off, then the payloads, moments and weight together, as esba's `solve3d` does; or from a
  `{name}_state` every load moves together (a warm start). The stable branch is followed by
  continuation (tangent predictor, with a second-order term from the last step's tangent where it
  is small; Newton corrector; the 3n x 3n Hessian factored as LDL^T). Where
  the branch ends (its steps shrink to nothing while the Hessian turns singular) the critical
  mode is found by inverse iteration; the state is kicked along it, the energy minimised just past
  the end, and the ramp goes on from where it lands: `ESBA_SNAPPED` when the mode lies in the
  bending plane, `ESBA_BUCKLED` when more than half of it lies out of the plane (psi, tau): the
  actuator flipped sideways. At a symmetric branch point both sides are tried (the mode's largest
  entry positive first; the nearer landing state is kept): under loads in the plane a sideways
  buckled state and its mirror image are equally valid answers.
- `{name}_equilibrium_batch(n, count, params, loads, out, work)`: the same for `count` scenes.
- `{name}_pressure_for_angle(n, params, loads, total_angle, max_pressure, from, out, work)`: the
  pressure in [0, max_pressure] MPa whose stable equilibrium under the 3-D loads has the total
  in-plane angle `total_angle` (rad): the branch is followed in that angle (Newton on the
  equilibrium bordered by the angle's equation) from the equilibrium at P = 0; a target no stable
  state of the branch meets is `ESBA_UNREACHABLE` with the nearest reachable state; an answer the
  load history at its pressure does not reach is flagged `ESBA_FLAG_MULTISTABLE`.
- `{name}_newton(n, params, loads, q0, out, work)`: Newton from `q0` at fixed loads.
- `{name}_stiffness(n, params, loads, q, out, work)`: the tip's 6 x 6 tangent compliance
  C = J H^-1 J^T and stiffness K = C^-1 at an equilibrium: rows and columns the tip force (x, y, z;
  N) and moment (about x, y, z; N mm) added at the tip as dead loads, the tip's translation (mm)
  and rotation (rad) in the base frame; J is the exact Jacobian of the generated kinematics.
- `{name}_energy`, `{name}_gradient`, `{name}_hessian` (3n x 3n, row-major), `{name}_tip` (tip,
  rotation, points): the model itself. `{name}_status_name`, `{name}_flag_name`,
  `{name}_work_bytes`, `{name}_default_params`, `{name}_default_loads`.

A converged state has max |dU/dq| below {tol['GRAD_TOL']:g} N mm/rad; a Hessian pivot within
{tol['CRITICAL_TOL']:g} of the largest counts as critical.

## Status codes

{STATUS_TABLE3D}
## Flags: results outside the model's range

The planar export's rule (`esba.model.validity`) applied to the in-plane angles theta:

{flag_table()}"""
