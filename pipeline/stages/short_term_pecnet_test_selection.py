"""Stage `short_term_pecnet_test_selection@<fold>`: a labelled compat diagnostic of upstream
PECNet's epoch selection on the TEST set, on one ETH/UCY fold; never a headline number.

PECNet is retrained as `train_short_term_baseline@<fold>-pecnet` trains it, in a temporary folder
(the stage's checkpoints are never touched), and after every epoch the test windows are scored
under our protocol and PECNet's with the K and seed of the headline's first scoring round
(`pipeline.studies.short_term_test_selection`). The record: per epoch the validation ADE and both
protocols' test ADE / FDE; the epoch kept on validation and its test numbers (checked against the
headline's training and first round); upstream's best test ADE and best test FDE over epochs.
A compat switch: on a fold not in `short_term_pecnet_test_selection.folds` the record says it is
off. Params: `short_term_pecnet_test_selection.folds`, `profile`, `runtime.device`,
`short_term.n_past`, `short_term.n_future`, `train_baseline`, `pecnet.<profile>`,
`short_term_models.<profile>` (the benchmark's epochs and K, `val_windows`, `seed`),
`short_term_baselines.<profile>.pecnet.<benchmark>`.

    python -m pipeline.stages.short_term_pecnet_test_selection --dataset eth \
        --windows data/short_term --training-facts metrics/short_term/train/eth_pecnet.json \
        --run-metrics metrics/short_term/runs/eth_pecnet.json \
        --out metrics/short_term/pecnet_test_selection/eth.json
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import torch

from pipeline.benchmarks.registry import SHORT_TERM
from pipeline.config.loading import (active_profile, load_profile, load_section, profile_entry,
                                     read_params)
from pipeline.config.pecnet import PecnetConfig
from pipeline.config.runtime import RuntimeParams
from pipeline.config.short_term import ShortTermParams
from pipeline.config.short_term_models import ShortTermModelsParams
from pipeline.config.short_term_pecnet_test_selection import ShortTermPecnetTestSelectionParams
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.device import TRAINING, select_device
from pipeline.io import exit_on_bad_intermediate, write_json
from pipeline.studies.pecnet_test_selection import summary_line
from pipeline.runners.short_term_baselines import SECTION, BaselineOverrides
from pipeline.studies.short_term_test_selection import (MODEL, SWITCH, RetrainSettings, fold_record,
                                                        switched_off_record, switched_on)


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, choices=SHORT_TERM)
    parser.add_argument("--windows", type=Path, required=True,
                        help="short_term_windows output folder (tables and ETH/UCY scene index)")
    parser.add_argument("--training-facts", type=Path, required=True,
                        help="of train_short_term_baseline (the headline's kept epoch)")
    parser.add_argument("--run-metrics", type=Path, required=True,
                        help="of evaluate_short_term_baseline (the headline's first round)")
    parser.add_argument("--out", type=Path, required=True, help="JSON written")
    args = parser.parse_args(argv)
    params = read_params()
    profile = active_profile(params)
    switch = load_section(ShortTermPecnetTestSelectionParams, SWITCH, params)
    if not switched_on(args.dataset, switch):
        record = switched_off_record(args.dataset, profile)
        print(f"short_term_pecnet_test_selection {args.dataset}: {record['not_run_reason']}")
        write_json(record, args.out)
        return
    retrain = RetrainSettings(
        profile, load_profile(ShortTermModelsParams, "short_term_models", params),
        load_section(ShortTermParams, "short_term", params),
        load_section(TrainBaselineParams, "train_baseline", params),
        load_profile(PecnetConfig, MODEL, params),
        BaselineOverrides(profile, profile_entry(params, SECTION)))
    torch.set_num_threads(retrain.train_baseline.threads)
    device = select_device(load_section(RuntimeParams, "runtime", params).device, purpose=TRAINING)
    with tempfile.TemporaryDirectory(prefix="short_term_pecnet_test_selection_") as scratch:
        record = fold_record(args.dataset, retrain, args.windows, args.training_facts,
                             args.run_metrics, Path(scratch) / f"{args.dataset}_pecnet", device)
    kept, compat = record["validation_selected"], record["compat"]
    for protocol in record["protocols"]:
        print(f"short_term_pecnet_test_selection {args.dataset} "
              f"{summary_line(kept, compat, protocol, 3, record['unit'])}")
    print(f"short_term_pecnet_test_selection {args.dataset}: the headline's epoch and first round "
          f"reproduced: {record['training_reproduced']['same']}")
    write_json(record, args.out)


if __name__ == "__main__":
    main()
