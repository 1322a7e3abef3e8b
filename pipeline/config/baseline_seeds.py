"""Section `baseline_seeds` of params.yaml: the long-term baselines' extra training seeds."""

from __future__ import annotations

from dataclasses import dataclass, field

from pipeline.config.loading import seed_list_error


@dataclass
class BaselineSeedsParams:
    """Section `baseline_seeds`: every trained long-term baseline again with other training seeds
    (stages `train_baseline_seed`, `evaluate_baseline_seed`, `evaluate_rpecnet_seed`), so the report
    can show how far training alone moves the metrics. One list for both profiles: DVC 3.67's
    matrix cannot take `${baseline_seeds.${profile}}`."""

    extra: list[int] = field(default_factory=lambda: [1, 2])
    """Training seeds besides `train_baseline.seed` (whose models are the report's main numbers);
    [] trains none."""

    def __post_init__(self):
        wrong = seed_list_error(self.extra)
        if wrong:
            raise ValueError(f"extra {wrong}")
