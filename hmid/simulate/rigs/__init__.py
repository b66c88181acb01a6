"""The simulated rigs, each a :class:`~hmid.simulate.rig.SimulatedRig` with its data set.

* ``hydro_muscle`` / ``hydro_muscle_dataset``: the Hydro Muscle rig of thesis Ch. 4 (a muscle
  lifting a hanging mass along a rail), its dynamic-loading and free-fall logs;
* ``linear_motor`` / ``linear_motor_dataset``: a linear-motor positioning stage under a PD loop,
  its logs of random references;
* ``ankle`` / ``ankle_params``: the multi-fibre bionic ankle of thesis Ch. 6 (a planar joint
  turned by eight fibres, five of them on valves): a plant for control, without a data set.

A new rig is two modules like these: the physics (a ``SimulatedRig``: parameters, state and one
sample's step, what its trajectory holds) and the data set (a ``RigDataset``: its logs, sensors,
column maps and truth record), registered by its ``kind`` in :mod:`hmid.simulate.datasets`.
"""
