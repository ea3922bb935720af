"""The environment layer of the task suite (paper §IV): a task (:class:`~taskcond.envs.protocol.Task`) in
a PyBullet kitchen behind the Gymnasium API (:class:`~taskcond.envs.kitchen.KitchenEnv`), with the
per-step reading and blow-up check in :mod:`taskcond.envs.reader`. Needs the ``[sim]`` extra.

Layers: :mod:`taskcond.sim` builds and reads the scene and knows nothing of tasks or environments; this
package steps a scene for a task it knows only through :class:`~taskcond.envs.protocol.Task`;
:mod:`taskcond.tasks` defines the tasks, their success checks and oracles, and imports this package, never
the reverse.
"""
