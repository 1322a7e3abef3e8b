"""The short-term datasets, written out once, as `pipeline.model_list` writes out the models.

A short-term stage names its dataset (`--dataset`): `sdd` (TrajNet's SDD split) or one of the
ETH/UCY leave-one-scene-out folds (`pipeline.splits.FOLD_TEST_SCENES`, whose keys are the fold
names). A dataset's settings sit in params.yaml under its benchmark's settings key, `sdd` or
`ethucy` (`k_<key>`, `ynet_<key>`, `rel_threshold.<key>`, `epochs.<model>.<key>`). Config checks
params against these lists and the short-term benchmarks (`pipeline.benchmarks.registry`) are
named by them; like the model list, this module sits below both.
"""

from __future__ import annotations

from pipeline.splits import FOLD_TEST_SCENES

SDD = "sdd"
"""TrajNet's SDD split: its `--dataset` and its settings key."""
ETHUCY = "ethucy"
"""The settings key every ETH/UCY fold shares."""

SHORT_TERM_DATASETS = (SDD, *FOLD_TEST_SCENES)
"""Every short-term `--dataset`: sdd, then the five ETH/UCY folds."""
SHORT_TERM_SETTINGS_KEYS = (SDD, ETHUCY)
"""The short-term benchmarks' settings keys in params.yaml."""
