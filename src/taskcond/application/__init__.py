"""The application layer: what ``taskcond run``, ``taskcond eval`` and ``taskcond reproduce`` do, apart from
parsing and printing. An episode (:mod:`.episode`) puts the executor core (:mod:`taskcond.execution`) into the
PyBullet world adapter (:mod:`taskcond.worlds.kitchen`) on a suite task; condition sources, workers and
evaluations build on episodes.
"""
