"""The model: scenes, the generated CasADi models, and what follows from them without solving.

:mod:`.scene` (an actuator, its loads and settings, validated and frozen), :mod:`.generated`
(finding, checking and loading the models that ``derive`` emitted, generating a missing one on
demand), :mod:`.closed_form` (the unloaded pressure of a target angle), :mod:`.structured` (the O(n)
linear algebra of the chain's Hessian), :mod:`.stability` (verdicts from eigenvalues),
:mod:`.validity` (where a result leaves the paper's model), :mod:`.resolution` (what the
solver can resolve), :mod:`.section` (the cross-section: torsion constant, shear centre and
stiffnesses, by finite elements) and :mod:`.contact` (obstacles in a scene and the surfaces of the
body they touch). May import :mod:`esba.infra` and ``derive``.
"""
