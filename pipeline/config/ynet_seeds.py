"""Section `ynet_seeds` of params.yaml: the main Y-net trained again with other training seeds."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from pipeline.config.loading import ParamsError, seed_list_error


@dataclass(frozen=True)
class YnetSeedsParams:
    """Section `ynet_seeds.<profile>`: the main Y-net trained again with other training seeds
    (stages `train_ynet_seed@<slot>`, `evaluate_ynet_seed@<slot>`), for the report's training-seed
    spread. The stages DVC builds are the slots `ynet_seeds.slots` (`ynet_seed_slots`); a slot not
    listed here writes a not-run record giving `why_not`."""

    seeds: list[int] = field(default_factory=list)
    """Training seeds besides `ynet.<profile>.seed` (the main model); [] trains none."""
    why_not: str = ""
    """Why this profile trains no (or only these) extra seeds; required when `seeds` is empty."""

    def __post_init__(self):
        wrong = seed_list_error(self.seeds)
        if wrong:
            raise ValueError(f"seeds {wrong}")
        if not self.seeds and not self.why_not.strip():
            raise ValueError("why_not must say why this profile trains no extra Y-net seed")

    def not_run_reason(self, profile: str, seed: int | None = None) -> str:
        """Why Y-net is not trained with `seed` (None: with any extra seed) in `profile`."""
        what = f"with seed {seed}" if seed is not None else "with extra training seeds"
        reason = (f"Y-net is not trained {what} in the {profile} profile (its extra seeds here: "
                  f"{', '.join(map(str, self.seeds)) or 'none'})")
        return f"{reason}: {self.why_not}" if self.why_not.strip() else reason


def ynet_seed_slots(params: dict[str, Any]) -> list[int]:
    """`ynet_seeds.slots`: the seeds the `train_ynet_seed` / `evaluate_ynet_seed` stages exist for."""
    section = params.get("ynet_seeds")
    if not isinstance(section, dict) or "slots" not in section:
        raise ParamsError("params.yaml: missing ynet_seeds.slots")
    wrong = seed_list_error(section["slots"])
    if wrong:
        raise ParamsError(f"params.yaml:ynet_seeds.slots {wrong}")
    return list(section["slots"])
