"""Section `compat` of params.yaml: the authors' bugs this pipeline can reproduce on request."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class CompatParams:
    drop_first_row: bool = False
    """Reproduce the authors' `read_csv(header=0)` bug: drop the first annotation of every file."""
