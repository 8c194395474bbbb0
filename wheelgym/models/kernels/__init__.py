"""Public compiled pieces of the dynamic and kinematic models (one module per robot).

``three_wheel``, ``skid_steer``, ``caster_agv`` and ``kinematic`` each hold a robot's compiled
functions (Jacobian rows, mass matrix, bias, friction, the one-state and block derivatives) and
the ``P_*`` indices of its packed parameter array (``Model.packed``), and instantiate the
model's batch kernels from the generic bodies of :mod:`wheelgym.integrators`. The models, the
environments' step kernels and the controllers all inline these, so every layer computes the
same bits. Not imported here: a robot's module loads (from numba's cache) on first use.
"""
