"""numba kernels of the rig model (and the plain modules they share with the real-time loop: ``layout``, ``vmath``).

Importing this package imports nothing of numba: :mod:`rig_env.physics.layout` (the parameter columns)
and :mod:`rig_env.physics.vmath` (lazily compiled :mod:`~rig_env.physics.jit` kernels) are used by the
rig's numba-free real-time loop.  The kernel modules (``integrator``, ``lanes``, ``joint_space``,
``aero``, ``dae``...) import numba themselves.  numba's set-up for this package (a source-keyed cache
directory and the inliner fix :mod:`rig_env.physics.fast_inline`) happens before any of them is
decorated or compiled: :func:`rig_env.physics.jit.setup_numba`, run as soon as numba is imported in a
process that imported :mod:`rig_env` (``RIG_ENV_FAST_INLINE=0`` turns the fix off).
"""
