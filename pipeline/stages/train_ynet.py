"""Stage `train_ynet`: Y-net on the release's t_f = 30 train windows, the epoch selected on val.

One scene per batch under rotation/flip augmentation; after every epoch a validation score
(never the test set), a checkpoint and the best weights so far (`pipeline.runners.ynet_main`,
`pipeline.runners.ynet_training`; `train_ynet_seed` is the same with another training seed).
Resumes after an interruption; SIGTERM / SIGINT or `runtime.max_minutes` checkpoint mid-epoch and
exit 143 / 130 / 75. Params: `ynet.<profile>`, `profile`, `runtime.device`, `runtime.max_minutes`
(and `windows.n_past`, passed as --n-past).

    python -m pipeline.stages.train_ynet --windows data/windows/release_tf30.parquet \
        --semantic-maps data/semantic_maps --sdd data/raw/sdd --n-past 5 \
        --checkpoint-dir checkpoints/ynet --model data/ynet/model.pt \
        --history reports/training/ynet_train.csv --metrics metrics/ynet_train.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.ynet import YnetSettings
from pipeline.device import TRAINING, describe, select_device
from pipeline.io import exit_on_bad_intermediate, write_json
from pipeline.preemption import Preemption, exit_when_stopped
from pipeline.runners.ynet_main import train_main


@exit_when_stopped
@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=Path, required=True, help="window table (parquet)")
    parser.add_argument("--semantic-maps", type=Path, required=True)
    parser.add_argument("--sdd", type=Path, required=True, help="fetched SDD root (scene sizes)")
    parser.add_argument("--n-past", type=int, default=5)
    parser.add_argument("--checkpoint-dir", type=Path, required=True)
    parser.add_argument("--model", type=Path, required=True, help="best weights (state_dict)")
    parser.add_argument("--history", type=Path, required=True, help="per-epoch CSV (dvc plots)")
    parser.add_argument("--metrics", type=Path, required=True)
    args = parser.parse_args(argv)
    params = read_params()
    settings = load_profile(YnetSettings, "ynet", params)
    runtime = load_section(RuntimeParams, "runtime", params)
    device = select_device(runtime.device, purpose=TRAINING)

    with Preemption(runtime.max_minutes) as preemption:
        summary = train_main(args.windows, args.semantic_maps, args.sdd, args.n_past, settings,
                             args.checkpoint_dir, args.model, args.history, device, preemption)
    print(f"train_ynet: trained on {describe(device)}")
    summary["profile"] = active_profile(params)
    write_json(summary, args.metrics)


if __name__ == "__main__":
    main()
