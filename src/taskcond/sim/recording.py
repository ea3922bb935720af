"""Headless video of an episode (mp4 through imageio-ffmpeg, or GIF), for ``taskcond oracle --video``.

Frames are RGB arrays (H, W, 3) uint8 as returned by :meth:`taskcond.envs.kitchen.KitchenEnv.render`.
"""

from __future__ import annotations

from pathlib import Path
from types import TracebackType

import imageio.v2 as imageio
import numpy as np


class VideoRecorder:
    """Write frames to ``path``; the format follows the suffix (``.mp4`` or ``.gif``).

    Use as a context manager or call :meth:`close`.
    """

    def __init__(self, path: str | Path, fps: int = 15) -> None:
        self.path = Path(path)
        suffix = self.path.suffix.lower()
        if suffix not in (".mp4", ".gif"):
            raise ValueError(f"unsupported video format {suffix!r}; valid: .mp4, .gif")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if suffix == ".mp4":
            self._writer = imageio.get_writer(self.path, fps=fps, codec="libx264", macro_block_size=8)
        else:
            self._writer = imageio.get_writer(self.path, mode="I", duration=1.0 / fps, loop=0)
        self.frames = 0

    def add(self, frame: np.ndarray) -> None:
        """Append one RGB frame (H, W, 3) uint8."""
        self._writer.append_data(np.asarray(frame, dtype=np.uint8))
        self.frames += 1

    def close(self) -> None:
        self._writer.close()

    def __enter__(self) -> VideoRecorder:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
