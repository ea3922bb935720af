"""World adapters: implementations of the executor's :class:`~taskcond.execution.world.World` over a simulator
(:mod:`.kitchen`, the PyBullet kitchen suite; :mod:`.robosuite`, robosuite's MuJoCo tasks). A new world is a
new module here."""
