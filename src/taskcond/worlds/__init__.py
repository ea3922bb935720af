"""Worlds beyond the PyBullet kitchen that the condition-guided executor runs in (each implements
:class:`taskcond.execution.world.World`)."""
