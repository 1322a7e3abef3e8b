"""Section `runtime` of params.yaml: where torch runs and how long a training call may take
(`pipeline.device`, `pipeline.preemption`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class RuntimeParams:
    """Section `runtime` of params.yaml: where torch runs and how long a training call may take."""

    device: str = "auto"
    """auto (CUDA when available) | cpu | cuda | cuda:N."""
    max_minutes: float = 0.0
    """Training stages save a mid-epoch checkpoint and stop (exit code 75) after this many minutes
    of one invocation; the next `dvc repro` resumes. 0 = no limit."""

    def __post_init__(self):
        parse_device_name(self.device)  # raises on a malformed name
        if self.max_minutes < 0:
            raise ValueError(f"max_minutes must be >= 0 (0 = no limit), got {self.max_minutes}")


def parse_device_name(name: str) -> tuple[str, int | None]:
    """'auto' | 'cpu' | 'cuda' | 'cuda:N' -> (kind, index); anything else is a ValueError."""
    if name in ("auto", "cpu", "cuda"):
        return name, None
    kind, _, index = name.partition(":")
    if kind == "cuda" and index.isdigit():
        return kind, int(index)
    raise ValueError(f"device must be auto, cpu, cuda or cuda:N, got {name!r}")
