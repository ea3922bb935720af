"""The PyBullet kitchen task suite (paper §IV). Needs the ``[sim]`` extra."""
