"""Section `short_term_pecnet_test_selection` of params.yaml: the ETH/UCY folds the short-term
compat diagnostic runs on."""

from __future__ import annotations

from dataclasses import dataclass, field

from pipeline.splits import FOLD_TEST_SCENES


@dataclass(frozen=True)
class ShortTermPecnetTestSelectionParams:
    """Section `short_term_pecnet_test_selection`: the compat switch of stage
    `short_term_pecnet_test_selection@<fold>`, never a headline number. On the folds listed, PECNet
    is retrained as the headline trains it and its test windows scored after every epoch (upstream's
    selection on test); on the others the stage records that it is switched off."""

    folds: list[str] = field(default_factory=list)
    """ETH/UCY folds the diagnostic runs on ([]: switched off)."""

    def __post_init__(self):
        unknown = sorted(set(self.folds) - set(FOLD_TEST_SCENES))
        if unknown:
            raise ValueError(f"folds {unknown} are not ETH/UCY folds ({', '.join(FOLD_TEST_SCENES)})")
        if len(set(self.folds)) != len(self.folds):
            raise ValueError(f"folds repeat: {self.folds}")
