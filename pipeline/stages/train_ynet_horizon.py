"""Stage `train_ynet_horizon@<t_f>`: Y-net trained at one prediction horizon (paper Figure 4).

Trains on the horizon table's train split (the epoch selected on val), with `ynet.<profile>`'s
settings, the epochs `ynet_horizons.<profile>.epochs` gives this horizon and the waypoints scaled
with the horizon (`pipeline.runners.ynet_horizon`); with `ynet_horizons.<profile>.init_from_main`
it starts from `--main-model` (the main 30-s Y-net, `ynet.model.weights_for_horizon`) instead of a
random init. Writes the checkpoint folder (`last.pt`,
`best.pt`, `history.csv`; an interrupted run resumes, and SIGTERM / SIGINT or `runtime.max_minutes`
checkpoint mid-epoch and exit 143 / 130 / 75) and the training record. A horizon the profile does
not train gets the not-run record and an empty checkpoint folder. Params: `profile`,
`runtime.device`, `runtime.max_minutes`, `ynet.<profile>`, `ynet_horizons.<profile>.epochs`,
`ynet_horizons.<profile>.why_subset`, `ynet_horizons.<profile>.init_from_main`, `windows.n_past`.

    python -m pipeline.stages.train_ynet_horizon --horizon 10 --table data/horizon_windows/tf10.parquet \
        --semantic-maps data/semantic_maps --sdd data/raw/sdd --main-model data/ynet/model.pt \
        --checkpoint-dir checkpoints/ynet_tf10 --metrics metrics/ynet_horizons/train_tf10.json
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.windows import WindowParams
from pipeline.config.ynet import YnetSettings
from pipeline.config.ynet_horizons import HorizonParams
from pipeline.data.labels import image_sizes
from pipeline.data.semantic_maps import load_semantic_maps
from pipeline.device import TRAINING, describe, select_device
from pipeline.io import exit_on_bad_intermediate, write_json
from pipeline.preemption import Preemption, exit_when_stopped
from pipeline.runners.ynet_horizon import horizon_splits, not_run_record
from pipeline.runners.ynet_training import horizon_start, scale_waypoints, train


@exit_when_stopped
@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--horizon", type=int, required=True, help="t_f in seconds")
    parser.add_argument("--table", type=Path, required=True, help="horizon window table (parquet)")
    parser.add_argument("--semantic-maps", type=Path, required=True)
    parser.add_argument("--sdd", type=Path, required=True, help="fetched SDD root (scene sizes)")
    parser.add_argument("--main-model", type=Path, required=True,
                        help="the main Y-net (train_ynet), the init with init_from_main")
    parser.add_argument("--checkpoint-dir", type=Path, required=True)
    parser.add_argument("--metrics", type=Path, required=True, help="training record (JSON)")
    args = parser.parse_args(argv)
    params = read_params()
    profile = active_profile(params)
    horizon_params = load_profile(HorizonParams, "ynet_horizons", params)
    if args.horizon not in horizon_params.horizons:
        args.checkpoint_dir.mkdir(parents=True, exist_ok=True)  # a declared output, even empty
        write_json(not_run_record(args.horizon, profile, horizon_params), args.metrics)
        print(f"train_ynet_horizon: t_f = {args.horizon} s not trained in the {profile} profile")
        return

    settings = load_profile(YnetSettings, "ynet", params)
    n_past = load_section(WindowParams, "windows", params).n_past
    runtime = load_section(RuntimeParams, "runtime", params)
    device = select_device(runtime.device, purpose=TRAINING)

    splits = horizon_splits(args.table, n_past, args.horizon)
    epochs = {int(h): int(e) for h, e in horizon_params.epochs.items()}[args.horizon]
    settings = replace(settings, epochs=epochs,
                       waypoints=scale_waypoints(settings.waypoints, args.horizon))
    semantic_maps = load_semantic_maps(args.semantic_maps)
    initial_weights = (horizon_start(args.main_model, settings, n_past, args.horizon)
                       if horizon_params.init_from_main else None)
    args.checkpoint_dir.mkdir(parents=True, exist_ok=True)  # after the inputs are checked
    scene_ids = set().union(*(arrays.scene_id for arrays in splits.values()))
    sizes = image_sizes(args.sdd, scene_ids)
    with Preemption(runtime.max_minutes) as preemption:
        summary = train(splits["train"], splits["val"], semantic_maps, sizes, settings, n_past,
                        args.checkpoint_dir / "last.pt", args.checkpoint_dir / "best.pt",
                        args.checkpoint_dir / "history.csv", device=device, preemption=preemption,
                        initial_weights=initial_weights)
    print(f"train_ynet_horizon: trained on {describe(device)}")
    write_json({"t_f": args.horizon, "profile": profile, "trained": True,
                "waypoints": settings.waypoints,
                "init": "main model" if horizon_params.init_from_main else "random", **summary},
               args.metrics)


if __name__ == "__main__":
    main()
