"""The kitchen task suite of the paper's §IV: primitive and long-horizon tasks with ground-truth success
checks and scripted oracles, each run in a :class:`taskcond.envs.kitchen.KitchenEnv`. Needs the ``[sim]``
extra.

Entry points: :func:`taskcond.tasks.registry.list_tasks`, :func:`taskcond.tasks.registry.make`,
:func:`taskcond.tasks.oracle.run_oracle`.
"""
