"""Physics simulator of the rigs (stand-in for lab data).

:mod:`~hmid.simulate.rig` says what a simulated rig provides and integrates any of them;
:mod:`~hmid.simulate.dataset` says what a rig's data set provides; :mod:`~hmid.simulate.write`
writes any data set with its ground truth; :mod:`~hmid.simulate.datasets` reads a config as its
rig's. The rigs themselves live in :mod:`hmid.simulate.rigs`; :mod:`~hmid.simulate.effects` holds
the switchable effects of the Hydro Muscle rig.
"""
