"""The kitchen task suite of the paper's §IV: primitive and long-horizon tasks as Gymnasium-style
environments with ground-truth success checks and scripted oracles. Needs the ``[sim]`` extra.

Entry points: :func:`taskcond.tasks.registry.list_tasks`, :func:`taskcond.tasks.registry.make`,
:func:`taskcond.tasks.oracle.run_oracle`.
"""
