"""Stage `train_ynet_seed@<seed>`: the main Y-net trained again with another training seed.

Exactly `train_ynet` (`pipeline.runners.ynet_main.train_main`: the release's t_f = 30 windows, the
semantic maps, `ynet.<profile>`'s settings, the epoch selected on val) with `--seed` in place of
`ynet.<profile>.seed`: the seed sets the initial weights, the batch order and the augmentation
draws. Writes the checkpoint folder (`last.pt`, `best.pt`, `history.csv`; an interrupted run
resumes, and SIGTERM / SIGINT or `runtime.max_minutes` checkpoint mid-epoch and exit 143 / 130 /
75) and the training record (`train_ynet`'s summary, the seed, the validation curve). A seed the
active profile does not list in `ynet_seeds.<profile>.seeds` trains nothing: it gets the not-run
record giving `why_not` and an empty checkpoint folder. Params: `ynet.<profile>`,
`ynet_seeds.<profile>`, `profile`, `runtime.device`, `runtime.max_minutes` (and `windows.n_past`,
passed as --n-past).

    python -m pipeline.stages.train_ynet_seed --seed 1 --windows data/windows/release_tf30.parquet \
        --semantic-maps data/semantic_maps --sdd data/raw/sdd --n-past 5 \
        --checkpoint-dir checkpoints/ynet_seeds/seed1 --metrics metrics/ynet_seeds/train_seed1.json
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.ynet import YnetSettings
from pipeline.config.ynet_seeds import YnetSeedsParams
from pipeline.device import TRAINING, describe, select_device
from pipeline.io import exit_on_bad_intermediate, write_json
from pipeline.preemption import Preemption, exit_when_stopped
from pipeline.runners.ynet_main import seed_not_run_record, seed_training_record, train_main


@exit_when_stopped
@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, required=True, help="training seed (a ynet_seeds slot)")
    parser.add_argument("--windows", type=Path, required=True, help="window table (parquet)")
    parser.add_argument("--semantic-maps", type=Path, required=True)
    parser.add_argument("--sdd", type=Path, required=True, help="fetched SDD root (scene sizes)")
    parser.add_argument("--n-past", type=int, default=5)
    parser.add_argument("--checkpoint-dir", type=Path, required=True)
    parser.add_argument("--metrics", type=Path, required=True, help="training record (JSON)")
    args = parser.parse_args(argv)
    params = read_params()
    profile = active_profile(params)
    seeds = load_profile(YnetSeedsParams, "ynet_seeds", params)
    if args.seed not in seeds.seeds:
        args.checkpoint_dir.mkdir(parents=True, exist_ok=True)  # a declared output, even empty
        write_json(seed_not_run_record(args.seed, profile, seeds), args.metrics)
        print(f"train_ynet_seed: seed {args.seed} not trained in the {profile} profile")
        return

    settings = replace(load_profile(YnetSettings, "ynet", params), seed=args.seed)
    runtime = load_section(RuntimeParams, "runtime", params)
    device = select_device(runtime.device, purpose=TRAINING)
    args.checkpoint_dir.mkdir(parents=True, exist_ok=True)
    history = args.checkpoint_dir / "history.csv"
    with Preemption(runtime.max_minutes) as preemption:
        summary = train_main(args.windows, args.semantic_maps, args.sdd, args.n_past, settings,
                             args.checkpoint_dir, args.checkpoint_dir / "best.pt", history, device,
                             preemption)
    print(f"train_ynet_seed: seed {args.seed} trained on {describe(device)}")
    write_json(seed_training_record(args.seed, profile, summary, history), args.metrics)


if __name__ == "__main__":
    main()
