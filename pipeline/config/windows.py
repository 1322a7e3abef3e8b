"""Section `windows` of params.yaml: the long-term windows (observed steps, horizons, frame
rates)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class WindowParams:
    n_past: int = 5
    """Observed steps (n_p) at the target frame rate."""
    horizons: list[int] = field(default_factory=lambda: [5, 10, 15, 20, 30, 40, 50, 60])
    """Prediction horizons t_f in seconds; one window table each."""
    raw_fps: int = 30
    """Frame rate of the raw annotations."""
    target_fps: int = 1
    """Frame rate of the windows; raw_fps must be a multiple of it."""
    label: str = "Pedestrian"
    """Agent class kept."""
    release_horizon: int = 30
    """t_f of the authors' released windows."""

    def __post_init__(self):
        if self.n_past < 2:
            raise ValueError("n_past must be at least 2 (a velocity needs two points)")
        if not self.horizons or min(self.horizons) < 1:
            raise ValueError("horizons must be a non-empty list of positive seconds")
        if self.raw_fps < 1 or self.target_fps < 1:
            raise ValueError(f"raw_fps and target_fps must be >= 1, got {self.raw_fps}, {self.target_fps}")
        if self.release_horizon < 1:
            raise ValueError(f"release_horizon must be >= 1 s, got {self.release_horizon}")
        if self.raw_fps % self.target_fps:
            raise ValueError(f"raw_fps {self.raw_fps} is not a multiple of target_fps {self.target_fps}")

    @property
    def stride(self) -> int:
        """Raw frames between two kept frames."""
        return self.raw_fps // self.target_fps

    def window_length(self, t_f: int) -> int:
        return self.n_past + t_f * self.target_fps
